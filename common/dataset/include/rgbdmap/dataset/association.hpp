#pragma once
// Timestamp association as in the TUM RGB-D benchmark's associate.py: every pair closer than max_dt is a
// candidate; candidates are taken greedily by smallest time difference (ties: smaller a, then smaller b),
// each timestamp is used at most once, and the result is sorted by a's timestamp.
#include <cstddef>
#include <utility>
#include <vector>

namespace rgbdmap {

/// One matched pair: indices into the a and b timestamp lists given to associate().
struct IndexPair {
  size_t a = 0;
  size_t b = 0;
};

/// Greedy closest-pair association (|t_a - t_b| < max_dt, strictly, as associate.py). Inputs need not be
/// sorted; non-finite timestamps never match. Output sorted by a's timestamp (then b's).
std::vector<IndexPair> associate(const std::vector<double>& a_timestamps,
                                 const std::vector<double>& b_timestamps, double max_dt);

}  // namespace rgbdmap
