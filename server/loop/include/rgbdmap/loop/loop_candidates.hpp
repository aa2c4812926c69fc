#pragma once
// Loop candidates for a new keyframe (Hu et al. 2017, sec. 3.2, extended for several robots): the k most
// recent keyframes of the same robot (local loops), l random older ones of the same robot (random loops),
// keyframes near the current pose estimate in the same map frame, and appearance-retrieval hits over all
// robots. The union is deduplicated (sources merged), the keyframe itself excluded, and capped.
#include <cstdint>
#include <random>
#include <vector>

#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/loop/binary_words.hpp"

namespace rgbdmap {

struct LoopCandidateConfig {
  int recent_k = 5;                ///< local loops: the k most recent keyframes of the same robot
  int random_l = 5;                ///< random loops: l random same-robot keyframes older than the recent k
  double nearby_radius_m = 1.0;    ///< nearby: camera centres within this distance (same map frame) ...
  double nearby_angle_deg = 45.0;  ///< ... and optical axes within this angle
  int nearby_max = 3;              ///< closest nearby keyframes kept (not already recent)
  int retrieval_top_n = 5;         ///< appearance hits (any robot)
  int exclude_recent = 15;         ///< retrieval skips this many most recent keyframes of the same robot
  int max_candidates = 15;         ///< cap on the union (order: recent, retrieval, nearby, random)
  unsigned seed = 1;               ///< random-loop sampling (the detector owns one seeded generator)
};

/// Where a candidate came from (bit flags; a candidate may have several).
enum CandidateSource : uint8_t {
  kSourceRecent = 1,
  kSourceRandom = 2,
  kSourceNearby = 4,
  kSourceRetrieval = 8,
};
constexpr int kCandidateSourceCount = 4;
/// "recent", "random", "nearby", "retrieval" for bit index 0..3.
const char* candidateSourceName(int bit);

/// What candidate selection needs to know about a keyframe.
struct KeyframeSummary {
  int id = -1;
  int robot_id = 0;
  int map_id = 0;  ///< frame of T_map_kf; poses in different map frames are not comparable
  SE3 T_map_kf = SE3::Identity();
};

struct LoopCandidate {
  int keyframe_id = -1;
  uint8_t sources = 0;           ///< CandidateSource bits
  double retrieval_score = 0.0;  ///< > 0 when a retrieval hit
};

/// stored: earlier keyframes in insertion order (all robots). hits: retrieval results for `query`.
std::vector<LoopCandidate> selectLoopCandidates(const KeyframeSummary& query,
                                                const std::vector<KeyframeSummary>& stored,
                                                const std::vector<RetrievalHit>& hits,
                                                const LoopCandidateConfig& config, std::mt19937* rng);

/// True if b's camera is within the radius and axis angle of a's (same map frame required).
bool isNearby(const KeyframeSummary& a, const KeyframeSummary& b, double radius_m, double angle_deg);

}  // namespace rgbdmap
