#pragma once
// Helpers for the whitespace-separated text files of the TUM format (trajectories, image lists):
// data lines with their numbers (blank lines and '#' comments skipped) and strict number parsing.
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap {

struct TextLine {
  int number = 0;  ///< 1-based line number in the source
  std::vector<std::string> fields;
};

/// Every non-blank, non-comment line split on whitespace (CR tolerated).
std::vector<TextLine> dataLines(const std::string& text);

/// The whole number in `token` (no trailing characters), finite; otherwise the reason, naming the field
/// when `what` is given: "[what ]'x' is not a number", "what is not finite" / "non-finite value".
Result<double> parseFiniteNumber(const std::string& token, const std::string& what = "");

/// Shortest readable form of a number (printf %g), e.g. "0.02", "1": for messages.
std::string formatShort(double value);
/// Shortest decimal text that reads back as exactly `value` (for files read back: camera.yaml).
std::string formatExact(double value);
/// A TUM timestamp: seconds with 6 decimals (microseconds).
std::string formatTimestamp(double seconds);

/// The contents of a file, or "<path>: cannot open".
Result<std::string> readTextFile(const std::string& path);

/// Writes `text` to a temporary file beside `path`, syncs it, renames it over `path` and syncs the folder:
/// readers see the old file or the whole new one, and a crash right after leaves the new one on disk.
/// writeFileAtomic (atomic_file.hpp) under a name for text; on failure the old file stays.
Status writeTextFileAtomic(const std::string& path, const std::string& text);

/// "a, b,c" -> {"a", "b", "c"}: comma-separated items, blanks around them trimmed, empty items dropped.
std::vector<std::string> splitList(const std::string& text);

}  // namespace rgbdmap
