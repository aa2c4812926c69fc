#pragma once
// The concrete sources behind openFrameSource (one file each) and the wrappers it composes.
#include <memory>

#include "rgbdmap/source/frame_source.hpp"

namespace rgbdmap::source_detail {

Result<std::unique_ptr<FrameSource>> openTumSource(const SourceUrl& url, const SourceOptions& options);
Result<std::unique_ptr<FrameSource>> openBagSource(const SourceUrl& url, const SourceOptions& options);
Result<std::unique_ptr<FrameSource>> openMcapSource(const SourceUrl& url, const SourceOptions& options);
Result<std::unique_ptr<FrameSource>> openRos2Source(const SourceUrl& url, const SourceOptions& options);
Result<std::unique_ptr<FrameSource>> openSevenScenesSource(const SourceUrl& url,
                                                           const SourceOptions& options);
Result<std::unique_ptr<FrameSource>> openOpenni2Source(const SourceUrl& url, const SourceOptions& options);

}  // namespace rgbdmap::source_detail
