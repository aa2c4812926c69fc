#pragma once
// bench_map_growth's world: synthetic rooms 20 m apart, built on demand, and the order of the laps.
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap::bench {

/// The rooms of the world, built on demand (a room is deterministic by its seed) and kept a few at a time.
class World {
 public:
  World(int per_lap, int width, int height) : per_lap_(per_lap) {
    const double s = width / 640.0;
    camera_ = {525.0 * s,
               525.0 * (height / 480.0),
               (width - 1) / 2.0,
               (height - 1) / 2.0,
               width,
               height,
               {0.0, 0.0, 0.0, 0.0, 0.0},
               5000.0,
               0.0};
  }
  const CameraIntrinsics& camera() const { return camera_; }
  size_t roomsKept() const { return rooms_.size(); }
  /// Room r (null, with the reason on stderr, when it cannot be built).
  const SyntheticScene* room(int r) {
    if (auto it = rooms_.find(r); it != rooms_.end()) return it->second.get();
    if (rooms_.size() >= 4) rooms_.erase(rooms_.begin());  // the oldest ids: revisits go back to r/2
    SynthConfig c;
    c.scene = "loop";
    c.frames = per_lap_;
    c.seed = static_cast<uint64_t>(r) + 1;
    c.camera = camera_;
    auto scene = SyntheticScene::build(c);
    if (!scene) {
      std::fprintf(stderr, "bench_map_growth: room %d: %s\n", r, scene.error().c_str());
      return nullptr;
    }
    return rooms_.emplace(r, std::make_unique<SyntheticScene>(std::move(*scene))).first->second.get();
  }
  /// Where room r lies in the world.
  static SE3 T_world_room(int r) {
    SE3 T = SE3::Identity();
    T.translation() = Vec3(20.0 * r, 0.0, 0.0);
    return T;
  }

 private:
  int per_lap_;
  CameraIntrinsics camera_;
  std::map<int, std::unique_ptr<SyntheticScene>> rooms_;
};

/// Room of each lap: 0, 1, ..., with a lap of room r/2 after every `revisit_every` new rooms.
inline std::vector<int> lapPlan(int laps, int revisit_every) {
  std::vector<int> plan;
  for (int r = 0; static_cast<int>(plan.size()) < laps; ++r) {
    plan.push_back(r);
    if (r > 0 && r % revisit_every == 0) plan.push_back(r / 2);
  }
  plan.resize(laps);
  return plan;
}

}  // namespace rgbdmap::bench
