#include "rgbdmap/vision/features.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <opencv2/imgproc.hpp>

namespace rgbdmap {

size_t FrameFeatures::countWithDepth() const {
  return static_cast<size_t>(std::count_if(depth_m.begin(), depth_m.end(), [](double d) { return d > 0; }));
}

OrbExtractor::OrbExtractor(const OrbConfig& config) : config_(config) {
  // Over-detect, then bucket down to n_features so that texture-rich regions do not take everything.
  orb_ = cv::ORB::create(config.n_features * 2, config.scale_factor, config.n_levels, 19, 0, 2,
                         cv::ORB::HARRIS_SCORE, 31, config.fast_threshold);
}

std::vector<cv::KeyPoint> OrbExtractor::bucket(std::vector<cv::KeyPoint> keypoints, cv::Size size) const {
  const int target = config_.n_features;
  if (static_cast<int>(keypoints.size()) <= target) return keypoints;
  std::sort(keypoints.begin(), keypoints.end(),
            [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
  const int cols = std::max(1, config_.grid_cols), rows = std::max(1, config_.grid_rows);
  const int quota = std::max(1, target / (cols * rows));
  std::vector<int> per_cell(cols * rows, 0);
  std::vector<char> taken(keypoints.size(), 0);
  std::vector<cv::KeyPoint> out;
  out.reserve(target);
  for (size_t i = 0; i < keypoints.size() && static_cast<int>(out.size()) < target; ++i) {
    const int cx = std::clamp(static_cast<int>(keypoints[i].pt.x * cols / size.width), 0, cols - 1);
    const int cy = std::clamp(static_cast<int>(keypoints[i].pt.y * rows / size.height), 0, rows - 1);
    if (per_cell[cy * cols + cx] < quota) {
      ++per_cell[cy * cols + cx];
      taken[i] = 1;
      out.push_back(keypoints[i]);
    }
  }
  // Fill what the sparse cells left over with the strongest remaining corners.
  for (size_t i = 0; i < keypoints.size() && static_cast<int>(out.size()) < target; ++i)
    if (!taken[i]) out.push_back(keypoints[i]);
  return out;
}

void OrbExtractor::detectAndDescribe(const cv::Mat& gray, std::vector<cv::KeyPoint>* keypoints,
                                     cv::Mat* descriptors) const {
  std::vector<cv::KeyPoint> detected;
  orb_->detect(gray, detected);
  *keypoints = bucket(std::move(detected), gray.size());
  orb_->compute(gray, *keypoints, *descriptors);
}

namespace {

/// True when the valid depth within `radius` pixels of (x, y) spans more than `max_spread` of `z` (missing
/// pixels, the sensor's shadows, do not count: they carry no depth to disagree with).
bool onDepthEdge(const RgbdFrame& frame, int x, int y, double z, int radius, double max_spread) {
  const cv::Mat& d = frame.depth;
  const int x0 = std::max(0, x - radius), x1 = std::min(d.cols - 1, x + radius);
  const int y0 = std::max(0, y - radius), y1 = std::min(d.rows - 1, y + radius);
  const double limit = max_spread * z * frame.depth_scale;  // in depth units
  uint16_t lo = UINT16_MAX, hi = 0;
  for (int r = y0; r <= y1; ++r) {
    const uint16_t* row = d.ptr<uint16_t>(r);
    for (int c = x0; c <= x1; ++c) {
      const uint16_t v = row[c];
      if (v == 0) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  return hi > lo && static_cast<double>(hi - lo) > limit;
}

}  // namespace

FrameFeatures OrbExtractor::extract(const RgbdFrame& frame, const PinholeCamera& camera) const {
  cv::Mat gray;
  if (frame.color.channels() == 3)
    cv::cvtColor(frame.color, gray, cv::COLOR_BGR2GRAY);
  else
    gray = frame.color;
  FrameFeatures f;
  detectAndDescribe(gray, &f.keypoints, &f.descriptors);
  const size_t n = f.keypoints.size();
  f.px.resize(n);
  f.depth_m.resize(n);
  f.p_cam.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f& pt = f.keypoints[i].pt;
    f.px[i] = camera.undistort(Eigen::Vector2d(pt.x, pt.y));
    const int x = static_cast<int>(std::lround(pt.x)), y = static_cast<int>(std::lround(pt.y));
    const double z = frame.depthMetres(x, y);
    const bool valid = z >= config_.min_depth_m && z <= config_.max_depth_m &&
                       (config_.depth_edge_radius_px <= 0 ||
                        !onDepthEdge(frame, x, y, z, config_.depth_edge_radius_px, config_.depth_edge_max_spread));
    f.depth_m[i] = valid ? z : 0.0;
    f.p_cam[i] = valid ? camera.backProject(f.px[i], z) : Vec3::Zero();
  }
  return f;
}

}  // namespace rgbdmap
