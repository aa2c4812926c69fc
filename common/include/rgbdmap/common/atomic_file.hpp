#pragma once
// Files that appear whole or not at all: every file the programs write (map files, summaries, trajectories,
// datasets) goes through writeFileAtomic. The bytes go to a temporary file beside the target (same folder,
// so the rename stays on one file system), which is synced, renamed over the target, and the folder synced:
// a reader sees the old file or the whole new one, a crash or a full disk never leaves a truncated file in
// place of a good one, and after success the new file survives power loss.
#include <string>
#include <string_view>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap {

struct AtomicWriteOptions {
  /// fsync the file before the rename and the folder after it. false: still whole-or-nothing for readers
  /// and for a killed process, but not after power loss (for bulk outputs that are synced as a whole later,
  /// see syncFolder).
  bool sync = true;
};

/// Writes `bytes` to `path` atomically (see above). On failure the temporary file is removed, the old file
/// at `path` (if any) is untouched, and the reason names the file and the system error.
Status writeFileAtomic(const std::string& path, std::string_view bytes, AtomicWriteOptions options = {});

/// fsyncs a folder (its entries: files created or renamed in it). The reason on failure.
Status syncFolder(const std::string& dir);

/// The folder part of a path: "a/b/c.txt" -> "a/b", "c.txt" -> ".", "/c" -> "/".
std::string folderOf(const std::string& path);

}  // namespace rgbdmap
