// Depth image -> the keyframe cloud kept for insertion and rebuilds: sampled pixels, undistorted rays,
// range limits, then one mean point (and colour) per camera-frame voxel.
#include <cmath>
#include <sstream>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

#include "rgbdmap/map/map_config_tables.hpp"
#include "rgbdmap/map/occupancy_map.hpp"

namespace rgbdmap {
namespace {

struct VoxelSum {
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  Eigen::Vector3i rgb = Eigen::Vector3i::Zero();
  int n = 0;
};

/// 21 bits per axis, offset so that negative cells are fine (a 2^20-cell range each way).
int64_t voxelKey(const Eigen::Vector3f& p, float inv_voxel) {
  const auto cell = [&](float v) { return static_cast<int64_t>(std::floor(v * inv_voxel)) + (1 << 20); };
  return (cell(p.x()) << 42) | (cell(p.y()) << 21) | cell(p.z());
}

std::string checkImages(const cv::Mat& depth16, double depth_scale, const cv::Mat& bgr, int width,
                        int height) {
  std::ostringstream why;
  if (depth16.type() != CV_16UC1) why << "depth must be CV_16UC1; ";
  if (depth16.cols != width || depth16.rows != height)
    why << "depth is " << depth16.cols << "x" << depth16.rows << ", camera " << width << "x" << height
        << "; ";
  if (!bgr.empty() && (bgr.type() != CV_8UC3 || bgr.size() != depth16.size()))
    why << "colour must be empty or CV_8UC3 of the depth's size; ";
  if (!(std::isfinite(depth_scale) && depth_scale > 0)) why << "depth_scale must be finite and > 0; ";
  std::string s = why.str();
  return s.empty() ? s : s.substr(0, s.size() - 2);
}

}  // namespace

int OccupancyMapConfig::pixelStride(double fx) const {
  if (pixel_stride > 0) return pixel_stride;
  const double voxel = cloud_voxel_fraction > 0 ? cloudVoxelM() : 0.5 * resolution_m;
  return std::max(1, static_cast<int>(std::floor(voxel * fx / max_range_m)));
}

size_t KeyframeCloud::memoryBytes() const {
  return sizeof(*this) + points_cam.capacity() * sizeof(Eigen::Vector3f) +
         colors_rgb.capacity() * sizeof(colors_rgb[0]);
}

KeyframeCloudMaker::KeyframeCloudMaker(const PinholeCamera& camera, const OccupancyMapConfig& config)
    : config_(config),
      width_(camera.width()),
      height_(camera.height()),
      stride_(config.pixelStride(camera.intrinsics().fx)) {
  const CameraIntrinsics& k = camera.intrinsics();
  for (int v = 0; v < height_; v += stride_)
    for (int u = 0; u < width_; u += stride_) {
      const Eigen::Vector2d px = camera.intrinsics().hasDistortion() ? camera.undistort(Eigen::Vector2d(u, v))
                                                                     : Eigen::Vector2d(u, v);
      rays_.emplace_back(static_cast<float>((px.x() - k.cx) / k.fx),
                         static_cast<float>((px.y() - k.cy) / k.fy));
    }
}

Result<KeyframeCloud> KeyframeCloudMaker::make(int64_t keyframe_id, const cv::Mat& depth16,
                                               double depth_scale, const cv::Mat& bgr) const {
  if (const std::string why = checkImages(depth16, depth_scale, bgr, width_, height_); !why.empty())
    return Result<KeyframeCloud>::failure("keyframe " + std::to_string(keyframe_id) + ": " + why);
  const bool colors = config_.keep_colors && !bgr.empty();
  const float scale = static_cast<float>(1.0 / depth_scale);
  const float z_min = static_cast<float>(config_.min_range_m);
  // Beyond max range only the ray direction matters: clamp just past it so far points share voxels.
  const float z_clamp = static_cast<float>(config_.max_range_m + config_.resolution_m);
  const float voxel = static_cast<float>(config_.cloudVoxelM());
  const float inv_voxel = voxel > 0 ? 1.0f / voxel : 0.0f;

  KeyframeCloud cloud;
  cloud.keyframe_id = keyframe_id;
  std::unordered_map<int64_t, VoxelSum> voxels;
  voxels.reserve(rays_.size() / 4);
  size_t r = 0;
  for (int v = 0; v < height_; v += stride_) {
    const uint16_t* d = depth16.ptr<uint16_t>(v);
    const cv::Vec3b* c = colors ? bgr.ptr<cv::Vec3b>(v) : nullptr;
    for (int u = 0; u < width_; u += stride_, ++r) {
      if (d[u] == 0) continue;
      Eigen::Vector3f p(rays_[r].x(), rays_[r].y(), 1.0f);
      p *= d[u] * scale;
      const float range = p.norm();
      if (range < z_min) continue;
      if (range > z_clamp) p *= z_clamp / range;
      const Eigen::Vector3i rgb = c ? Eigen::Vector3i(c[u][2], c[u][1], c[u][0]) : Eigen::Vector3i::Zero();
      if (inv_voxel == 0.0f) {
        cloud.points_cam.push_back(p);
        if (colors) cloud.colors_rgb.push_back({uint8_t(rgb[0]), uint8_t(rgb[1]), uint8_t(rgb[2])});
        continue;
      }
      VoxelSum& s = voxels[voxelKey(p, inv_voxel)];
      s.sum += p;
      s.rgb += rgb;
      ++s.n;
    }
  }
  cloud.points_cam.reserve(cloud.points_cam.size() + voxels.size());
  if (colors) cloud.colors_rgb.reserve(cloud.colors_rgb.size() + voxels.size());
  for (const auto& [key, s] : voxels) {
    cloud.points_cam.push_back(s.sum / static_cast<float>(s.n));
    if (colors)
      cloud.colors_rgb.push_back({static_cast<uint8_t>(s.rgb[0] / s.n), static_cast<uint8_t>(s.rgb[1] / s.n),
                                  static_cast<uint8_t>(s.rgb[2] / s.n)});
  }
  return cloud;
}

Result<KeyframeCloud> makeKeyframeCloud(int64_t keyframe_id, const cv::Mat& depth16, double depth_scale,
                                        const cv::Mat& bgr, const PinholeCamera& camera,
                                        const OccupancyMapConfig& config) {
  if (const std::string why = config.validate(); !why.empty())
    return Result<KeyframeCloud>::failure("invalid occupancy map config: " + why);
  return KeyframeCloudMaker(camera, config).make(keyframe_id, depth16, depth_scale, bgr);
}

std::string OccupancyMapConfig::validate() const {
  std::vector<std::string> problems = occupancyMapConfigTable().problems(*this);
  if (!(max_range_m > min_range_m)) problems.push_back("max_range_m must be above min_range_m");
  return joinProblems(problems);
}

}  // namespace rgbdmap
