#include "rgbdmap/ba/ba_synth.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace rgbdmap {
namespace {

SE3 keyframePose(int k, const BaSynthConfig& o) {
  SE3 T = SE3::Identity();
  T.translation() = Vec3(k * o.step_m, 0.02 * std::sin(k * 0.7), o.climb_per_m * k * o.step_m);
  T.linear() =
      se3::expSO3(Vec3(0.01 * std::cos(k), o.turn_rad_per_m * k * o.step_m, o.roll_rad_per_keyframe * k));
  return T;
}

}  // namespace

BaSynthScene makeBaSynthScene(const BaSynthConfig& o) {
  BaSynthScene s;
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> ux(-2.5, 2.5 + o.keyframes * o.step_m), uy(-1.5, 1.5), uz(1.5, 4.0);
  std::normal_distribution<double> px_noise(0.0, o.pixel_noise), d_noise(0.0, o.depth_noise);
  std::uniform_int_distribution<int> byte(0, 255), bit(0, 255), octave(0, 3);
  for (int i = 0; i < o.points; ++i) {
    s.points.emplace_back(ux(rng), uy(rng), uz(rng));
    std::array<uint8_t, 32> d;
    for (auto& b : d) b = static_cast<uint8_t>(byte(rng));
    s.descriptors.push_back(d);
  }
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < o.keyframes; ++k) {
    const SE3 T = keyframePose(k, o);
    s.T_map_kf.push_back(T);
    const Vec3 w = Vec3(unit(rng), unit(rng), unit(rng)).normalized() * o.rolling_shutter_rad;
    s.rolling_shutter.push_back(w);
    auto f = std::make_shared<FrameFeatures>();
    std::vector<int> owner;
    std::vector<std::array<uint8_t, 32>> rows;
    for (size_t i = 0; i < s.points.size(); ++i) {
      Vec3 p = T.inverse() * s.points[i];
      if (p.z() < 0.3) continue;
      // The row that sees the point depends on where it is seen: a few fixed-point steps.
      const Vec3 p_gs = p;
      for (int it = 0; it < 3 && o.rolling_shutter_rad > 0.0; ++it) {
        const double v_row = s.camera.fy * p.y() / p.z() + s.camera.cy;
        p = rollingShutterPoint(p_gs, w, (v_row - 240.0) / 480.0);
      }
      if (p.z() < 0.3) continue;
      const double u = s.camera.fx * p.x() / p.z() + s.camera.cx + px_noise(rng);
      const double v = s.camera.fy * p.y() / p.z() + s.camera.cy + px_noise(rng);
      if (u < 2 || v < 2 || u > 637 || v > 477) continue;
      cv::KeyPoint kp(static_cast<float>(u), static_cast<float>(v), 31.f);
      kp.octave = octave(rng);
      f->keypoints.push_back(kp);
      f->px.emplace_back(u, v);
      const double z = 1.0 / (1.0 / p.z() + d_noise(rng));
      f->depth_m.push_back(z);
      f->p_cam.emplace_back((u - s.camera.cx) / s.camera.fx * z, (v - s.camera.cy) / s.camera.fy * z, z);
      auto d = s.descriptors[i];
      for (int b = 0; b < o.flipped_bits; ++b) {
        const int at = bit(rng);
        d[at / 8] ^= static_cast<uint8_t>(1u << (at % 8));
      }
      rows.push_back(d);
      owner.push_back(static_cast<int>(i));
    }
    f->descriptors = cv::Mat(static_cast<int>(rows.size()), 32, CV_8U);
    for (size_t r = 0; r < rows.size(); ++r)
      std::copy(rows[r].begin(), rows[r].end(), f->descriptors.ptr<uint8_t>(static_cast<int>(r)));
    s.features.push_back(f);
    s.point_of_feature.push_back(owner);
  }
  return s;
}

EdgeMatches synthTrueMatches(const BaSynthScene& s, int a, int b) {
  EdgeMatches m;
  m.from = a;
  m.to = b;
  std::vector<int> in_b(s.points.size(), -1);
  for (size_t j = 0; j < s.point_of_feature[b].size(); ++j)
    in_b[s.point_of_feature[b][j]] = static_cast<int>(j);
  for (size_t i = 0; i < s.point_of_feature[a].size(); ++i)
    if (const int j = in_b[s.point_of_feature[a][i]]; j >= 0) m.pairs.emplace_back(static_cast<int>(i), j);
  return m;
}

LandmarkKeyframe synthKeyframe(const BaSynthScene& s, int k, const SE3& T_map_kf, int map_id) {
  LandmarkKeyframe kf;
  kf.id = k;
  kf.map_id = map_id;
  kf.camera = s.camera;
  kf.T_map_kf = T_map_kf;
  kf.features = s.features[k];
  return kf;
}

}  // namespace rgbdmap
