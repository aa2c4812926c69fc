#pragma once
// Deterministic synthetic RGB-D sequences with exact ground truth: a textured room with furniture,
// ray-cast through an ideal pinhole camera, with a Kinect-like depth sensor model. The default data of
// the demo and of the tests (odometry, loop closure, occupancy mapping).
//
// World frame: z up, floor at z = 0, room centred on the origin. Camera frame: optical (x right, y down,
// z forward). Poses are T_world_cam. Same config (seed included) => bit-identical images.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/rgbd_frame.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/dataset/trajectory.hpp"

namespace rgbdmap {

/// Kinect-like depth sensor model. With enabled = false depth is exact (only rounded to raw units).
struct SynthDepthNoise {
  bool enabled = true;
  double min_range_m = 0.4;  ///< closer surfaces read as missing (0)
  double max_range_m = 4.5;  ///< farther surfaces read as missing (0)
  /// Axial noise sigma(z) = sigma_base_m + sigma_quad * (z - min_range_m)^2 (Khoshelham/Nguyen model).
  double sigma_base_m = 0.0012;
  double sigma_quad = 0.0019;
  /// Disparity quantisation: z = baseline * fx / d with d rounded to disparity_step_px (0 = off).
  double baseline_m = 0.075;
  double disparity_step_px = 0.125;
  /// Surfaces seen at a larger angle between ray and normal return no depth.
  double grazing_max_deg = 80.0;
  /// Depth edges: a pixel whose neighbour is nearer by more than edge_jump_m + edge_jump_rel * z is
  /// missing (the far side of an object boundary); the second pixel out is missing with probability 1/2.
  double edge_jump_m = 0.03;
  double edge_jump_rel = 0.03;
  double dropout_probability = 0.002;  ///< isolated random holes
};

/// Colour camera model: optical blur (also anti-aliases object edges) and Gaussian pixel noise.
struct SynthImageNoise {
  double blur_sigma_px = 0.5;  ///< 0 = no blur
  double sigma = 1.5;          ///< grey levels per channel; 0 = no noise
};

struct SynthConfig {
  /// "loop": a closed ellipse near the room centre looking outward, turning 360 degrees, ending exactly
  /// at the start pose. "sweep": a ~1 m sideways sweep facing a wall 1.5-3 m away.
  std::string scene = "loop";
  int frames = 300;   ///< the whole path is covered whatever the count (2..100000)
  uint64_t seed = 1;  ///< furniture layout, textures and noise
  double fps = 30.0;  ///< frame i is at t0 + i / fps
  double t0 = 1000.0;
  double depth_time_offset_s = 0.0005;  ///< depth stamps are colour stamps + this (exercises association)
  /// Ideal pinhole (no distortion: the renderer is exact pinhole geometry), TUM-like 640x480.
  /// An ideal pinhole with a global shutter (readout 0): the renderer draws each image at one instant.
  CameraIntrinsics camera{525.0, 525.0, 319.5, 239.5, 640, 480, {0.0, 0.0, 0.0, 0.0, 0.0}, 5000.0, 0.0};
  SynthDepthNoise depth_noise;
  SynthImageNoise image_noise;

  /// Checks every value; returns an empty string when valid, else all reasons ("; "-separated).
  std::string validate() const;
  double colorTimestamp(int frame_index) const { return t0 + frame_index / fps; }
  double depthTimestamp(int frame_index) const { return colorTimestamp(frame_index) + depth_time_offset_s; }
};

/// Exact poses of every frame of config.scene (T_world_cam, stamped with the colour timestamps).
Result<Trajectory> makeSynthTrajectory(const SynthConfig& config);

/// An axis-aligned box of the scene, world frame, metres.
struct SynthBox {
  Eigen::AlignedBox3d bounds;
  std::string kind;  ///< "cabinet", "shelf", "desk", "object", ...
};

/// The first surface a ray meets.
struct SynthHit {
  double t = 0.0;            ///< hit point = origin + t * direction (direction need not be unit)
  Vec3 normal_world;         ///< unit normal, facing the ray
  int furniture_index = -1;  ///< index into furniture(), -1 for the room's walls, floor and ceiling
};

namespace synth {
struct SceneData;  // textures, boxes and materials (src/detail.hpp)
}

class SyntheticScene {
 public:
  /// Generates the room, furniture, textures and trajectory; fails on an invalid config.
  static Result<SyntheticScene> build(const SynthConfig& config);

  const SynthConfig& config() const;
  /// One pose per frame (the ground truth).
  const Trajectory& trajectory() const;

  /// Render colour (CV_8UC3 BGR) and depth (CV_16UC1, metres * depth_scale, 0 = missing) seen from
  /// T_world_cam. frame_index seeds the sensor noise and sets the timestamp. Thread-safe. A camera outside
  /// the room sees black with no depth.
  RgbdFrame render(const SE3& T_world_cam, int frame_index) const;
  /// render() at the trajectory's pose for frame_index, clamped to [0, config().frames - 1].
  RgbdFrame renderFrame(int frame_index) const;

  /// Exact ray cast against the scene; nullopt if the ray leaves the room without a hit (origin outside).
  std::optional<SynthHit> castRay(const Vec3& origin_world, const Vec3& direction_world) const;
  /// Unsigned distance from a point to the nearest surface (walls, floor, ceiling, furniture faces).
  double distanceToSurface(const Vec3& p_world) const;

  /// Inside of the room; its faces are the walls, floor (z = 0) and ceiling.
  const Eigen::AlignedBox3d& room() const;
  const std::vector<SynthBox>& furniture() const;

 private:
  explicit SyntheticScene(std::shared_ptr<const synth::SceneData> data) : data_(std::move(data)) {}
  std::shared_ptr<const synth::SceneData> data_;
};

/// Write a sequence in TUM layout into out_dir (created if missing; same-named files are overwritten):
/// rgb/<ts>.png, depth/<ts>.png (16-bit), rgb.txt, depth.txt, groundtruth.txt and camera.yaml
/// (camera: {fx, fy, cx, cy, width, height, distortion: [k1, k2, p1, p2, k3], depth_scale, readout_s: 0}).
Status writeSyntheticSequence(const SynthConfig& config, const std::string& out_dir);

}  // namespace rgbdmap
