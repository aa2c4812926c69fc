#pragma once
// When a map gets a global bundle adjustment. The optimiser's worker tells it what changed (keyframes added
// or merged into a map, edges that came into the landmark tracks) and what a global BA did; it answers which
// maps are due. No threads, no clock: the caller decides when to ask (after a batch, or when the map is
// quiet).
//
// The rules, per map:
//   - every `every_keyframes` keyframes added since its last global BA, once the map also grew by
//     `min_growth_fraction` of its keyframes (a large map is not adjusted as often as a small one);
//   - a large cycle closed or two chains joined: due once it grew by that fraction;
//   - asked for (the final refinement, a quiet map): every map changed since its last global BA;
//   - a global BA that stopped at its iteration cap (or a time limit) without lowering the error by 1 %
//     doubles the growth the next one waits for (up to x64); one that helps resets it;
//   - a map of more than `max_keyframes` keyframes (> 0) gets none: it counts as done (local BAs and the pose
//     graph carry it).
#include <cstddef>
#include <functional>
#include <map>
#include <set>

namespace rgbdmap {

struct GlobalScheduleConfig {
  int every_keyframes = 50;          ///< keyframes added to a map between its global BAs; 0: only when asked
  double min_growth_fraction = 0.1;  ///< growth since the last one, as a fraction of the map; 0: no rule
  int max_keyframes = 4000;          ///< larger maps get no global BA; 0: no limit
};

/// The outcome of a global BA, as the schedule needs it.
struct GlobalRunOutcome {
  bool unfinished = false;  ///< stopped by its iteration cap (or a time limit) before it converged
  double initial_rms_px = 0.0;
  double final_rms_px = 0.0;
};

class GlobalBundleSchedule {
 public:
  /// Keyframes of a map (the caller's topology).
  using KeyframeCount = std::function<size_t(int map)>;

  explicit GlobalBundleSchedule(GlobalScheduleConfig config = {}) : config_(config) {}

  /// A keyframe came into `map` (new, or merged in from another map).
  void keyframeAdded(int map);
  /// Something else changed `map` (an edge came into its landmark tracks).
  void mapChanged(int map) { changed_.insert(map); }

  /// The maps due after a batch. `asked`: the caller wants every changed map; `large_change`: a large cycle
  /// closed or chains joined in this batch.
  std::set<int> dueAfterBatch(bool asked, bool large_change, const KeyframeCount& keyframes) const;
  /// Whether `map` grew by min_growth_fraction (times its backoff) since its last global BA.
  bool grownEnough(int map, size_t keyframes) const;
  /// Whether a map of this many keyframes is past max_keyframes.
  bool overLimit(size_t keyframes) const;

  /// A global BA of `map` starts (or is skipped as over the limit): its growth counts from here.
  void started(int map);
  struct Verdict {
    bool fruitless = false;  ///< unfinished without lowering the error by 1 %
    int backoff = 1;         ///< the growth factor the map's next global BA waits for
  };
  /// The applied outcome of `map`'s global BA.
  Verdict finished(int map, const GlobalRunOutcome& outcome);

  /// Maps changed since their last global BA.
  const std::set<int>& changed() const { return changed_; }
  int backoff(int map) const;

 private:
  GlobalScheduleConfig config_;
  std::map<int, int> added_;    ///< map id -> keyframes added since its last global BA
  std::set<int> changed_;       ///< maps changed since their last global BA
  std::map<int, int> backoff_;  ///< map id -> growth factor after fruitless global BAs
};

}  // namespace rgbdmap
