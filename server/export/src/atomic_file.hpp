#pragma once
// Files that appear whole: written to a temporary name beside the target, synced, then renamed over it
// (rgbdmap::writeFileAtomic); on failure the previous file stays.
#include <string>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap::export_detail {

Status writeFileAtomically(const std::string& path, const std::string& bytes);

/// The whole file, or the reason it could not be read (missing, unreadable, larger than max_bytes).
Result<std::string> readWholeFile(const std::string& path, size_t max_bytes);

}  // namespace rgbdmap::export_detail
