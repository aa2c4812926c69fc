// SyntheticScene: construction and exact geometric queries (rendering is in synth_render.cpp).
#include <algorithm>
#include <limits>

#include <opencv2/core/utility.hpp>

#include "detail.hpp"

namespace rgbdmap {
namespace {

/// Unsigned distance from p to the surface of an axis-aligned box (inside or outside).
double distanceToBoxSurface(const Eigen::AlignedBox3d& box, const Vec3& p) {
  if (box.contains(p)) {
    const Vec3 to_lo = p - box.min(), to_hi = box.max() - p;
    return std::min(to_lo.minCoeff(), to_hi.minCoeff());
  }
  return box.exteriorDistance(p);
}

}  // namespace

Result<SyntheticScene> SyntheticScene::build(const SynthConfig& config) {
  const std::string invalid = config.validate();
  if (!invalid.empty()) return Result<SyntheticScene>::failure("invalid synthetic config: " + invalid);
  auto trajectory = makeSynthTrajectory(config);
  if (!trajectory) return Result<SyntheticScene>::failure(trajectory.error());
  auto data = std::make_shared<synth::SceneData>();
  data->config = config;
  data->trajectory = std::move(*trajectory);
  data->textures.resize(synth::kMaterialCount);
  cv::parallel_for_(cv::Range(0, synth::kMaterialCount), [&](const cv::Range& r) {
    for (int m = r.start; m < r.end; ++m)  // each texture has its own generator: order does not matter
      data->textures[static_cast<size_t>(m)] =
          synth::makeMaterialTexture(static_cast<synth::Material>(m), config.seed);
  });
  synth::buildRoom(data.get());
  return SyntheticScene(std::move(data));
}

const SynthConfig& SyntheticScene::config() const { return data_->config; }
const Trajectory& SyntheticScene::trajectory() const { return data_->trajectory; }
const Eigen::AlignedBox3d& SyntheticScene::room() const { return data_->room_bounds; }
const std::vector<SynthBox>& SyntheticScene::furniture() const { return data_->furniture; }

RgbdFrame SyntheticScene::renderFrame(int frame_index) const {
  const int last = static_cast<int>(data_->trajectory.size()) - 1;
  const int i = std::clamp(frame_index, 0, last);
  return render(data_->trajectory[static_cast<size_t>(i)].T_world_cam, i);
}

std::optional<SynthHit> SyntheticScene::castRay(const Vec3& origin_world, const Vec3& direction_world) const {
  if (!data_->room_bounds.contains(origin_world) || !(direction_world.squaredNorm() > 0.0))
    return std::nullopt;
  const Vec3 inv_d = synth::safeInverse(direction_world);
  int face = 0;
  double t = synth::exitRoom(data_->room, origin_world, inv_d, &face);
  SynthHit hit;
  for (size_t b = 0; b < data_->boxes.size(); ++b)
    if (synth::enterBox(data_->boxes[b], origin_world, inv_d, &t, &face))
      hit.furniture_index = static_cast<int>(b);
  hit.t = t;
  hit.normal_world = synth::faceNormal(face, hit.furniture_index < 0);
  return hit;
}

double SyntheticScene::distanceToSurface(const Vec3& p_world) const {
  double best = distanceToBoxSurface(data_->room_bounds, p_world);
  for (const SynthBox& box : data_->furniture)
    best = std::min(best, distanceToBoxSurface(box.bounds, p_world));
  return best;
}

}  // namespace rgbdmap
