#pragma once
// Frames from a recording's image messages: colour and depth paired by header stamp (each other's nearest,
// at most max_dt apart; unpaired ones dropped as TUM's association does), camera and size from the reader.
#include <memory>

#include "image_message_reader.hpp"
#include "rgbdmap/source/frame_source.hpp"

namespace rgbdmap::source_detail {

/// The URL's ?rgb=, ?depth=, ?info= over `defaults` (info_required when ?info= names one).
ImageTopics topicsFrom(const SourceUrl& url, ImageTopics defaults);

/// The source URL's max_dt (seconds in (0, 10)), else the options' max_time_diff.
Result<double> maxTimeDiff(const SourceUrl& url, const SourceOptions& options);

std::unique_ptr<FrameSource> makePairedSource(std::unique_ptr<ImageMessageReader> reader, double max_dt);

}  // namespace rgbdmap::source_detail
