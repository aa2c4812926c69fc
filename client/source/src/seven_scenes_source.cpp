// 7scenes:DIR - a Microsoft 7-Scenes sequence folder, its depth registered to its colour camera.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/source/seven_scenes.hpp"
#include "sources.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;

constexpr double kFrameRate = 30.0;        // the Kinect v1's, at which 7-Scenes was recorded
constexpr uint16_t kInvalidDepth = 65535;  // 7-Scenes' "no measurement"
constexpr size_t kMaxFrames = 1000000;     // a bound on the folder scan

std::string framePath(const std::string& dir, size_t i, const char* kind) {
  std::string number = std::to_string(i);
  if (number.size() < 6) number.insert(0, 6 - number.size(), '0');
  return (fs::path(dir) / ("frame-" + number + "." + kind)).string();
}

bool isFile(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

/// Rotation made exactly orthonormal (the nearest rotation through its quaternion).
SE3 rigid(const Eigen::Matrix4d& m) {
  return se3::fromQuatTrans(Eigen::Quaterniond(Mat3(m.topLeftCorner<3, 3>())), m.topRightCorner<3, 1>());
}

}  // namespace

SevenScenesCalibration SevenScenesCalibration::standard() {
  SevenScenesCalibration c;
  const CameraIntrinsics pinhole{
      585.0, 585.0, 319.5, 239.5, 640, 480, {0, 0, 0, 0, 0}, 1000.0, CameraIntrinsics{}.readout_s};
  c.depth_camera = pinhole;
  c.colour_camera = pinhole;
  c.colour_camera.fx = c.colour_camera.fy = 525.0;
  Eigen::Matrix4d m;
  m << 0.99996518012567637, 0.0026765126468950343, -0.0079041012313000904, -0.025558943178152542,   //
      -0.0027409311281316700, 0.99996302803027592, -0.0081504520778013286, 0.00010109636268061706,  //
      0.0078819942130445332, 0.0081718328771890631, 0.99993554558014031, 0.0020318321729487039,     //
      0, 0, 0, 1;
  c.T_colour_depth = rigid(m);
  return c;
}

cv::Mat registerDepth(const cv::Mat& depth, const CameraIntrinsics& from, const CameraIntrinsics& to,
                      const SE3& T_to_from, uint16_t invalid) {
  cv::Mat out(to.height, to.width, CV_16UC1, cv::Scalar(0));
  if (depth.type() != CV_16UC1) return out;
  std::vector<double> ray_x(depth.cols), ray_y(depth.rows);
  for (int u = 0; u < depth.cols; ++u) ray_x[u] = (u - from.cx) / from.fx;
  for (int v = 0; v < depth.rows; ++v) ray_y[v] = (v - from.cy) / from.fy;
  const Mat3 R = T_to_from.linear();
  const Vec3 t = T_to_from.translation();
  for (int v = 0; v < depth.rows; ++v) {
    const uint16_t* row = depth.ptr<uint16_t>(v);
    for (int u = 0; u < depth.cols; ++u) {
      if (row[u] == 0 || row[u] == invalid) continue;
      const double z = row[u] / from.depth_scale;
      const Vec3 p = R * Vec3(ray_x[u] * z, ray_y[v] * z, z) + t;
      if (!(p.z() > 0)) continue;
      const long x = std::lround(to.fx * p.x() / p.z() + to.cx);
      const long y = std::lround(to.fy * p.y() / p.z() + to.cy);
      if (x < 0 || y < 0 || x >= to.width || y >= to.height) continue;
      const double value = std::round(p.z() * to.depth_scale);
      const auto d = static_cast<uint16_t>(std::clamp(value, 1.0, 65534.0));
      uint16_t& cell = out.at<uint16_t>(static_cast<int>(y), static_cast<int>(x));
      if (cell == 0 || d < cell) cell = d;
    }
  }
  return out;
}

bool isSevenScenesFolder(const std::string& dir) {
  std::error_code ec;
  return !fs::exists(fs::path(dir) / "rgb.txt", ec) && isFile(framePath(dir, 0, "color.png"));
}

Result<SE3> parseSevenScenesPose(const std::string& text, const std::string& source_name) {
  std::istringstream in(text);
  std::vector<double> v;
  for (std::string token; in >> token;) {
    if (v.size() == 16) return Result<SE3>::failure(source_name + ": more than 16 numbers");
    auto x = parseFiniteNumber(token, "pose entry " + std::to_string(v.size() + 1));
    if (!x) return Result<SE3>::failure(source_name + ": " + x.error());
    v.push_back(*x);
  }
  if (v.size() != 16)
    return Result<SE3>::failure(source_name + ": expected a 4x4 matrix (16 numbers), got " +
                                std::to_string(v.size()));
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = v[4 * r + c];
  const Mat3 R = m.topLeftCorner<3, 3>();
  const double off = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
  if (off > 1e-3 || R.determinant() < 0)
    return Result<SE3>::failure(source_name +
                                ": the rotation is not a rotation (|R^T R - I| = " + formatShort(off) + ")");
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6)
    return Result<SE3>::failure(source_name + ": the last row is not 0 0 0 1");
  return rigid(m);
}

namespace source_detail {

class SevenScenesSource : public FrameSource {
 public:
  SevenScenesSource(std::string dir, size_t frames, std::optional<Trajectory> ground_truth, size_t first,
                    long long end)
      : dir_(std::move(dir)),
        calibration_(SevenScenesCalibration::standard()),
        ground_truth_(std::move(ground_truth)) {
    next_ = std::min(first, frames);
    end_ = end < 0 ? frames : std::clamp<size_t>(static_cast<size_t>(end), next_, frames);
  }

  FrameRead next() override {
    if (next_ >= end_) return FrameRead::end();
    const size_t i = next_++;
    const std::string colour_path = framePath(dir_, i, "color.png");
    const std::string depth_path = framePath(dir_, i, "depth.png");
    if (!isFile(colour_path)) return FrameRead::unreadable(i, colour_path + ": colour image not found");
    if (!isFile(depth_path)) return FrameRead::unreadable(i, depth_path + ": depth image not found");
    RgbdFrame frame;
    frame.color = cv::imread(colour_path, cv::IMREAD_COLOR);
    const cv::Mat raw = cv::imread(depth_path, cv::IMREAD_UNCHANGED);
    const CameraIntrinsics& c = calibration_.colour_camera;
    const CameraIntrinsics& d = calibration_.depth_camera;
    if (frame.color.type() != CV_8UC3 || frame.color.cols != c.width || frame.color.rows != c.height)
      return FrameRead::unreadable(i, colour_path + ": not a 640x480 colour image");
    if (raw.type() != CV_16UC1 || raw.cols != d.width || raw.rows != d.height)
      return FrameRead::unreadable(i, depth_path + ": not a 640x480 16-bit depth image");
    frame.depth = registerDepth(raw, d, c, calibration_.T_colour_depth, kInvalidDepth);
    frame.depth_scale = c.depth_scale;
    frame.timestamp = static_cast<double>(i) / kFrameRate;
    return FrameRead::ok(i, std::move(frame));
  }
  bool live() const override { return false; }
  std::optional<CameraIntrinsics> camera() const override { return calibration_.colour_camera; }
  std::string describe() const override { return "7scenes:" + dir_; }
  size_t sizeHint() const override { return end_ > next_ ? end_ - next_ : 0; }
  std::optional<Trajectory> groundTruth() const override { return ground_truth_; }

 private:
  std::string dir_;
  SevenScenesCalibration calibration_;
  std::optional<Trajectory> ground_truth_;
  size_t next_ = 0, end_ = 0;
};

namespace {

/// The colour camera's ground truth from the frames' pose files; a missing or malformed one is left out,
/// counted and named in one warning.
std::optional<Trajectory> readGroundTruth(const std::string& dir, size_t frames) {
  const SE3 T_depth_colour = SevenScenesCalibration::standard().T_colour_depth.inverse();
  Trajectory gt;
  size_t bad = 0;
  std::string first_problem;
  for (size_t i = 0; i < frames; ++i) {
    const std::string path = framePath(dir, i, "pose.txt");
    auto text = readTextFile(path);
    Result<SE3> pose = text ? parseSevenScenesPose(*text, path) : Result<SE3>::failure(text.error());
    if (!pose) {
      if (bad++ == 0) first_problem = pose.error();
      continue;
    }
    gt.push_back({static_cast<double>(i) / kFrameRate, *pose * T_depth_colour});
  }
  if (bad > 0)
    log::warn("7scenes:", dir, ": ", bad, " of ", frames,
              " poses left out of the ground truth (first: ", first_problem, ")");
  if (gt.empty()) return std::nullopt;
  return gt;
}

}  // namespace

Result<std::unique_ptr<FrameSource>> openSevenScenesSource(const SourceUrl& url,
                                                           const SourceOptions& options) {
  using R = Result<std::unique_ptr<FrameSource>>;
  std::error_code ec;
  if (!fs::is_directory(url.path, ec)) return R::failure(url.path + ": 7-Scenes folder does not exist");
  size_t frames = 0;
  while (frames < kMaxFrames && isFile(framePath(url.path, frames, "color.png"))) ++frames;
  if (frames == 0) return R::failure(url.path + ": not a 7-Scenes sequence (no frame-000000.color.png)");
  std::optional<Trajectory> gt = readGroundTruth(url.path, frames);
  log::info("7scenes:", url.path, ": ", frames, " frames, ground truth: ",
            gt ? std::to_string(gt->size()) + " poses (colour camera)" : std::string("none"));
  return R(std::make_unique<SevenScenesSource>(url.path, frames, std::move(gt), options.first_frame,
                                               options.end_frame));
}

}  // namespace source_detail
}  // namespace rgbdmap
