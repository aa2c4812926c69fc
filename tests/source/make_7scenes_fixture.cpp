// make_7scenes_fixture SEQ OUT: a TUM-layout sequence whose camera is 7-Scenes' colour camera (fx = fy =
// 525, cx 319.5, cy 239.5, no distortion; `rgbdmap synth` writes one) rewritten in the 7-Scenes layout:
// frame-NNNNNN.color.png (the colour as it is), frame-NNNNNN.depth.png (the depth as 7-Scenes' depth camera
// sees it: millimetres, 65535 = none) and frame-NNNNNN.pose.txt (the depth camera's pose, 4x4
// camera-to-world). The depth camera's image is found by ray casting into the colour camera's depth map (a
// few fixed-point steps per pixel), so that it has no holes of its own.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/source/seven_scenes.hpp"

using namespace rgbdmap;

namespace {

/// The depth (m) the depth camera sees at pixel (u, v), 0 when its ray meets no colour-camera depth.
double castDepth(const cv::Mat& colour_depth, double colour_scale, const SevenScenesCalibration& cal, int u,
                 int v) {
  const CameraIntrinsics& d = cal.depth_camera;
  const CameraIntrinsics& c = cal.colour_camera;
  const SE3 T_dc = cal.T_colour_depth.inverse();
  const Vec3 ray((u - d.cx) / d.fx, (v - d.cy) / d.fy, 1.0);
  double z = 1.5;
  for (int iter = 0; iter < 6; ++iter) {
    const Vec3 p = cal.T_colour_depth * (z * ray);
    const double x = c.fx * p.x() / p.z() + c.cx, y = c.fy * p.y() / p.z() + c.cy;
    const long xi = std::lround(x), yi = std::lround(y);
    if (xi < 0 || yi < 0 || xi >= colour_depth.cols || yi >= colour_depth.rows) return 0.0;
    const uint16_t raw = colour_depth.at<uint16_t>(static_cast<int>(yi), static_cast<int>(xi));
    if (raw == 0) return 0.0;
    const double zc = raw / colour_scale;
    z = (T_dc * Vec3((x - c.cx) / c.fx * zc, (y - c.cy) / c.fy * zc, zc)).z();
  }
  return z;
}

std::string poseText(const SE3& T) {
  std::string out;
  char line[160];
  for (int r = 0; r < 4; ++r) {
    std::snprintf(line, sizeof line, "%.9e\t%.9e\t%.9e\t%.9e\t\n", T.matrix()(r, 0), T.matrix()(r, 1),
                  T.matrix()(r, 2), T.matrix()(r, 3));
    out += line;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) return std::fprintf(stderr, "usage: make_7scenes_fixture SEQ OUT\n"), 2;
  auto dataset = TumDataset::open(argv[1]);
  if (!dataset) return std::fprintf(stderr, "make_7scenes_fixture: %s\n", dataset.error().c_str()), 1;
  if (!dataset->groundTruth()) return std::fprintf(stderr, "make_7scenes_fixture: no ground truth\n"), 1;
  const SevenScenesCalibration cal = SevenScenesCalibration::standard();
  std::filesystem::create_directories(argv[2]);
  const Trajectory& gt = *dataset->groundTruth();
  for (size_t i = 0; i < dataset->size(); ++i) {
    auto frame = dataset->load(i);
    if (!frame) return std::fprintf(stderr, "make_7scenes_fixture: %s\n", frame.error().c_str()), 1;
    const StampedPose* pose = nullptr;
    for (const StampedPose& p : gt)
      if (std::abs(p.timestamp - frame->timestamp) < 1e-4) pose = &p;
    if (!pose) return std::fprintf(stderr, "make_7scenes_fixture: frame %zu has no ground truth\n", i), 1;
    cv::Mat depth(cal.depth_camera.height, cal.depth_camera.width, CV_16UC1);
    for (int v = 0; v < depth.rows; ++v)
      for (int u = 0; u < depth.cols; ++u) {
        const double z = castDepth(frame->depth, frame->depth_scale, cal, u, v);
        depth.at<uint16_t>(v, u) = z > 0 ? static_cast<uint16_t>(std::lround(z * 1000.0)) : 65535;
      }
    char name[64];
    std::snprintf(name, sizeof name, "%s/frame-%06zu.", argv[2], i);
    if (!cv::imwrite(std::string(name) + "color.png", frame->color) ||
        !cv::imwrite(std::string(name) + "depth.png", depth))
      return std::fprintf(stderr, "make_7scenes_fixture: cannot write %s*\n", name), 1;
    std::ofstream(std::string(name) + "pose.txt") << poseText(pose->T_world_cam * cal.T_colour_depth);
  }
  std::fprintf(stderr, "make_7scenes_fixture: %zu frames in %s\n", dataset->size(), argv[2]);
  return 0;
}
