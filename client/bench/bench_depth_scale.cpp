// The depth sensor against the ground truth: does a recording's depth agree with the geometry of its
// motion? For frame pairs GAP frames apart, ORB matches are triangulated from the ground-truth poses alone
// (no depth) and the triangulated depth is compared with the depth image at the keypoint: a ratio of 1
// means the depth scale is right. Second, the depth change of each point between the two frames is
// compared with the ground truth's motion along the view: its slope against that motion is the error of
// depth differences (k - 1 for depth = k * true + c), independent of small pose rotation errors.
// Usage: bench_depth_scale [DATASET_DIR] [--gap N] [--step N] [--time-offset S] [--poses FILE]
//   --poses FILE  a trajectory (TUM format) instead of the dataset's ground truth, e.g. an estimate
//   --time-offset S  added to the frame stamps before the poses are looked up (camera to mocap clock)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/features2d.hpp>

#include "rgbdmap/client/odometry_config.hpp"
#include "rgbdmap/dataset/trajectory.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/vision/features.hpp"

namespace {
using namespace rgbdmap;

struct Options {
  std::string dir = std::string(RGBDMAP_SHARED_DATA_DIR) + "/tum_fr1_xyz_first500";
  int gap = 12;
  int step = 4;
  double time_offset = 0.0;
  std::string poses;
};

/// One triangulated match: depth from the poses, depth measured, its image radius (0 centre, 1 corner
/// of the inscribed ellipse), and, where both frames have depth, the depth-change residual and the
/// motion along the view it is compared with.
struct Sample {
  double z_tri = 0, depth = 0, radius = 0;
  double change_residual = NAN, motion_z = NAN;
};

std::optional<SE3> poseAt(const Trajectory& t, double stamp) {
  const auto it = std::lower_bound(t.begin(), t.end(), stamp,
                                   [](const StampedPose& p, double s) { return p.timestamp < s; });
  if (it == t.begin() || it == t.end()) return std::nullopt;
  const StampedPose& a = *(it - 1);
  const StampedPose& b = *it;
  if (b.timestamp - a.timestamp > 0.05) return std::nullopt;
  return se3::interpolate(a.T_world_cam, b.T_world_cam, (stamp - a.timestamp) / (b.timestamp - a.timestamp));
}

/// Triangulates the ray `ray_a` (frame a) against `ray_b` (frame b) for b's pose T_b_a: the depth along
/// ray_a (z = 1) minimising the distance between the rays; NaN when they are near parallel.
double triangulate(const Vec3& ray_a, const Vec3& ray_b, const SE3& T_b_a) {
  const Vec3 ra = T_b_a.linear() * ray_a, t = T_b_a.translation();
  const double m11 = ra.dot(ra), m12 = -ra.dot(ray_b), m22 = ray_b.dot(ray_b);
  const double r1 = -ra.dot(t), r2 = ray_b.dot(t), det = m11 * m22 - m12 * m12;
  return det > 1e-12 ? (r1 * m22 - m12 * r2) / det : NAN;
}

void measurePair(const FrameFeatures& fa, const FrameFeatures& fb, const SE3& T_b_a, const PinholeCamera& cam,
                 std::vector<Sample>* out) {
  std::vector<cv::DMatch> matches;
  cv::BFMatcher(cv::NORM_HAMMING, true).match(fa.descriptors, fb.descriptors, matches);
  const auto& k = cam.intrinsics();
  for (const cv::DMatch& m : matches) {
    const size_t ia = static_cast<size_t>(m.queryIdx), ib = static_cast<size_t>(m.trainIdx);
    const Vec3 ray_a = cam.backProject(fa.px[ia], 1.0), ray_b = cam.backProject(fb.px[ib], 1.0);
    const double z = triangulate(ray_a, ray_b, T_b_a);
    if (!(z > 0.3 && z < 5.0)) continue;
    const Vec3 p_b = T_b_a * (z * ray_a);
    const auto px_b = cam.project(p_b);
    const double parallax_deg =
        std::acos(std::clamp((T_b_a.linear() * ray_a).normalized().dot(ray_b.normalized()), -1.0, 1.0)) *
        180.0 / M_PI;
    if (!px_b || (*px_b - fb.px[ib]).norm() > 1.0 || parallax_deg < 3.0) continue;
    if (!fa.hasDepth(ia)) continue;
    Sample s;
    s.z_tri = z;
    s.depth = fa.depth_m[ia];
    const cv::Point2f& pt = fa.keypoints[ia].pt;
    s.radius =
        std::hypot((pt.x - k.width / 2.0) / (k.width / 2.0), (pt.y - k.height / 2.0) / (k.height / 2.0));
    if (fb.hasDepth(ib)) {
      s.change_residual = fb.depth_m[ib] - (T_b_a * (fa.depth_m[ia] * ray_a)).z();
      s.motion_z = T_b_a.translation().z();
    }
    out->push_back(s);
  }
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

void printRatios(const std::vector<Sample>& samples, const char* what, double Sample::*key,
                 const std::vector<double>& edges) {
  for (size_t b = 0; b + 1 < edges.size(); ++b) {
    std::vector<double> r;
    for (const Sample& s : samples)
      if (s.*key >= edges[b] && s.*key < edges[b + 1]) r.push_back(s.z_tri / s.depth);
    if (r.size() >= 50)
      std::printf("  %s %.1f-%.1f: %6zu points, ratio %.4f\n", what, edges[b], edges[b + 1], r.size(),
                  median(r));
  }
}

/// Least-squares line of the depth-change residual against the motion along the view (residuals beyond
/// 5 cm, wrong matches, left out): the slope is k - 1.
void printDepthChange(const std::vector<Sample>& samples) {
  double sxx = 0, sx = 0, sy = 0, sxy = 0, n = 0;
  for (const Sample& s : samples) {
    if (!std::isfinite(s.change_residual) || std::abs(s.change_residual) > 0.05) continue;
    sxx += s.motion_z * s.motion_z;
    sx += s.motion_z;
    sy += s.change_residual;
    sxy += s.motion_z * s.change_residual;
    n += 1;
  }
  const double det = n * sxx - sx * sx;
  if (n < 50 || det <= 0) return;
  std::printf(
      "depth change against the motion along the view: %.0f points, slope %+.4f (depth differences x %.4f)\n",
      n, (n * sxy - sx * sy) / det, 1.0 + (n * sxy - sx * sy) / det);
}

std::optional<Options> parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--gap" && has_value)
      o.gap = std::atoi(argv[++i]);
    else if (a == "--step" && has_value)
      o.step = std::atoi(argv[++i]);
    else if (a == "--time-offset" && has_value)
      o.time_offset = std::atof(argv[++i]);
    else if (a == "--poses" && has_value)
      o.poses = argv[++i];
    else if (a[0] != '-')
      o.dir = a;
    else
      return std::nullopt;
  }
  if (o.gap < 1 || o.step < 1) return std::nullopt;
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const auto opt = parse(argc, argv);
  if (!opt) {
    std::fprintf(
        stderr,
        "usage: bench_depth_scale [DATASET_DIR] [--gap N] [--step N] [--time-offset S] [--poses FILE]\n");
    return 2;
  }
  const auto dataset = TumDataset::open(opt->dir);
  if (!dataset) {
    std::printf("bench_depth_scale: skipped, no dataset (%s)\n", dataset.error().c_str());
    return 0;
  }
  std::optional<Trajectory> poses = dataset->groundTruth();
  if (!opt->poses.empty()) {
    auto read = readTumTrajectory(opt->poses);
    if (!read) {
      std::fprintf(stderr, "bench_depth_scale: %s\n", read.error().c_str());
      return 1;
    }
    poses = std::move(read).value();
  }
  if (!poses) {
    std::fprintf(stderr, "bench_depth_scale: %s has no ground truth; give --poses\n", opt->dir.c_str());
    return 1;
  }
  auto camera = readDatasetCamera(opt->dir);
  const CameraIntrinsics k = camera && *camera ? **camera : CameraIntrinsics{};
  const PinholeCamera cam(k);
  const OrbExtractor extractor(OdometryConfig{}.orb);
  std::vector<Sample> samples;
  int pairs = 0;
  for (size_t i = 0; i + static_cast<size_t>(opt->gap) < dataset->size();
       i += static_cast<size_t>(opt->step)) {
    const size_t j = i + static_cast<size_t>(opt->gap);
    const auto fa = dataset->load(i), fb = dataset->load(j);
    const auto pa = poseAt(*poses, dataset->entry(i).rgb_timestamp + opt->time_offset);
    const auto pb = poseAt(*poses, dataset->entry(j).rgb_timestamp + opt->time_offset);
    if (!fa || !fb || !pa || !pb) continue;
    const SE3 T_b_a = pb->inverse() * *pa;
    if (T_b_a.translation().norm() < 0.05) continue;  // too little baseline to triangulate
    measurePair(extractor.extract(*fa, cam), extractor.extract(*fb, cam), T_b_a, cam, &samples);
    ++pairs;
  }
  std::vector<double> all;
  for (const Sample& s : samples) all.push_back(s.z_tri / s.depth);
  std::printf("%s: %d frame pairs %d apart, time offset %+.3f s, %zu points\n", opt->dir.c_str(), pairs,
              opt->gap, opt->time_offset, samples.size());
  std::printf("triangulated depth / measured depth: median %.4f\n", median(all));
  printRatios(samples, "depth (m)", &Sample::depth, {0.3, 0.8, 1.2, 1.8, 3.0, 5.0});
  printRatios(samples, "image radius", &Sample::radius, {0.0, 0.3, 0.5, 0.7, 0.9, 1.5});
  printDepthChange(samples);
  return samples.empty() ? 1 : 0;
}
