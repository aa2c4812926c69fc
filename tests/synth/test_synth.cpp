#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <list>
#include <sstream>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;

constexpr double kDeg = M_PI / 180.0;

SynthConfig exactConfig(const std::string& scene = "loop") {
  SynthConfig c;
  c.scene = scene;
  c.depth_noise.enabled = false;
  c.image_noise.sigma = 0.0;
  return c;
}

/// Scenes are built once per test binary (textures take a few hundred milliseconds).
const SyntheticScene& scene(const SynthConfig& config) {
  static std::list<std::pair<std::string, SyntheticScene>> cache;  // stable references
  std::ostringstream key;
  key << config.scene << config.seed << config.frames << config.depth_noise.enabled
      << config.image_noise.sigma;
  for (const auto& [k, s] : cache)
    if (k == key.str()) return s;
  auto built = SyntheticScene::build(config);
  if (!built) throw std::runtime_error(built.error());
  cache.emplace_back(key.str(), *built);
  return cache.back().second;
}

/// Camera looking along yaw (about world z, 0 = +x) and pitch (> 0 looks up) from p_world.
SE3 lookFrom(const Vec3& p_world, double yaw, double pitch) {
  const Vec3 forward(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
  const Vec3 right = forward.cross(Vec3::UnitZ()).normalized();
  SE3 T = SE3::Identity();
  T.linear().col(0) = right;                 // x right
  T.linear().col(1) = forward.cross(right);  // y down
  T.linear().col(2) = forward;               // z forward
  T.translation() = p_world;
  return T;
}

/// World ray of pixel (x, y), scaled so that its camera-frame z is 1 (then ray parameter = depth).
Vec3 pixelRay(const SE3& T_world_cam, const CameraIntrinsics& k, int x, int y) {
  return T_world_cam.linear() * Vec3((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
}

bool sameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

TEST(SynthConfig, DefaultsAreValidAndBadValuesAreAllReported) {
  EXPECT_EQ(SynthConfig{}.validate(), "");
  SynthConfig c;
  c.scene = "maze";
  c.frames = 1;
  c.camera.distortion[0] = 0.1;
  c.camera.readout_s = 0.02;
  c.depth_noise.max_range_m = 20.0;  // beyond 65535 / 5000
  const std::string err = c.validate();
  for (const char* reason : {"scene", "frames", "distortion", "readout_s", "max_range_m"})
    EXPECT_NE(err.find(reason), std::string::npos) << reason << " missing from: " << err;
  const auto built = SyntheticScene::build(c);
  ASSERT_FALSE(built);
  EXPECT_NE(built.error().find("frames"), std::string::npos);
}

TEST(SynthScene, SameSeedGivesIdenticalImagesAndAnotherSeedDoesNot) {
  SynthConfig c;
  c.frames = 30;
  const auto a = SyntheticScene::build(c);
  const auto b = SyntheticScene::build(c);
  c.seed = 2;
  const auto other = SyntheticScene::build(c);
  ASSERT_TRUE(a && b && other);
  const RgbdFrame fa = a->renderFrame(7), fb = b->renderFrame(7), fo = other->renderFrame(7);
  EXPECT_TRUE(sameImage(fa.color, fb.color));
  EXPECT_TRUE(sameImage(fa.depth, fb.depth));
  EXPECT_FALSE(sameImage(fa.color, fo.color));
  EXPECT_FALSE(sameImage(fa.depth, fo.depth));
  // Outside the room there is nothing to see.
  const RgbdFrame outside = a->render(lookFrom(Vec3(10.0, 0.0, 1.0), M_PI, 0.0), 0);
  EXPECT_EQ(cv::countNonZero(outside.depth), 0);
  // The noise differs between frames even at the same pose.
  EXPECT_FALSE(sameImage(a->render(a->trajectory()[7].T_world_cam, 8).color, fa.color));
  ASSERT_EQ(fa.color.type(), CV_8UC3);
  ASSERT_EQ(fa.depth.type(), CV_16UC1);
  EXPECT_EQ(fa.color.size(), cv::Size(640, 480));
  EXPECT_DOUBLE_EQ(fa.timestamp, 1000.0 + 7.0 / 30.0);
}

TEST(SynthScene, DepthEqualsAnalyticDistanceToFloorCeilingAndWall) {
  const SyntheticScene& s = scene(exactConfig());
  const CameraIntrinsics& k = s.config().camera;
  const auto& room = s.room();
  // Looking straight down at the free floor in the middle of the room: every pixel reads 1.4 m.
  const RgbdFrame down = s.render(lookFrom(Vec3(0.1, -0.2, 1.4), 0.3, -M_PI / 2 + 1e-9), 0);
  double worst = 0.0;
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) worst = std::max(worst, std::abs(down.depthMetres(x, y) - 1.4));
  EXPECT_LT(worst, 1e-3);
  // Tilted views of the ceiling and of the +x wall above the furniture (<= 2.2 m tall, <= 0.6 m deep).
  struct View {
    SE3 T_world_cam;
    int axis;  // plane x = room max (0) or z = ceiling (2)
  };
  for (const View& v : {View{lookFrom(Vec3(0.2, -0.1, 1.2), 0.5, 1.0), 2},
                        View{lookFrom(Vec3(0.0, 0.0, 1.5), 0.0, 0.35), 0}}) {
    const RgbdFrame f = s.render(v.T_world_cam, 0);
    const Vec3 o = v.T_world_cam.translation();
    int checked = 0;
    for (int y = 0; y < k.height; y += 2) {
      for (int x = 0; x < k.width; x += 2) {
        const Vec3 d = pixelRay(v.T_world_cam, k, x, y);
        if (!(d[v.axis] > 0)) continue;
        const double t = (room.max()[v.axis] - o[v.axis]) / d[v.axis];  // ray/plane distance = depth
        const Vec3 hit = o + t * d;
        const Vec3 at_furniture_front = o + (2.4 - o.x()) / d.x() * d;
        const bool free = v.axis == 2 ? (std::abs(hit.x()) < 2.3 && std::abs(hit.y()) < 1.8)
                                      : (std::abs(hit.y()) < 1.8 && hit.z() < room.max().z() &&
                                         at_furniture_front.z() > 2.21);
        if (!free) continue;
        ++checked;
        ASSERT_NEAR(f.depthMetres(x, y), t, 1e-3) << "pixel " << x << "," << y << " axis " << v.axis;
      }
    }
    EXPECT_GT(checked, 3000) << "axis " << v.axis;
  }
}

TEST(SynthScene, BackProjectedDepthLiesOnTheSurfaces) {
  const SyntheticScene& exact = scene(exactConfig());
  const PinholeCamera cam(exact.config().camera);
  for (int i : {0, 100, 200}) {
    const RgbdFrame f = exact.renderFrame(i);
    const SE3& T_world_cam = exact.trajectory()[static_cast<size_t>(i)].T_world_cam;
    for (int y = 0; y < f.depth.rows; y += 3) {
      for (int x = 0; x < f.depth.cols; x += 3) {
        const double z = f.depthMetres(x, y);
        ASSERT_GT(z, 0.0) << "noise-free depth has no holes";
        const Vec3 p_world = T_world_cam * cam.backProject(Eigen::Vector2d(x, y), z);
        ASSERT_LT(exact.distanceToSurface(p_world), 1e-3) << "frame " << i << " pixel " << x << "," << y;
      }
    }
  }
}

TEST(SynthScene, NoisyDepthFollowsTheSensorModel) {
  const SyntheticScene& noisy = scene(SynthConfig{});
  const SynthDepthNoise& n = noisy.config().depth_noise;
  const PinholeCamera cam(noisy.config().camera);
  const RgbdFrame f = noisy.renderFrame(50);
  const SE3& T_world_cam = noisy.trajectory()[50].T_world_cam;
  int valid = 0, within = 0;
  for (int y = 0; y < f.depth.rows; y += 2) {
    for (int x = 0; x < f.depth.cols; x += 2) {
      const double z = f.depthMetres(x, y);
      if (z == 0.0) continue;
      EXPECT_GE(z, n.min_range_m - 0.1);
      EXPECT_LE(z, n.max_range_m + 0.3);
      const Vec3 p_world = T_world_cam * cam.backProject(Eigen::Vector2d(x, y), z);
      const double sigma = n.sigma_base_m + n.sigma_quad * (z - n.min_range_m) * (z - n.min_range_m);
      const double step = z * z / (n.baseline_m * cam.intrinsics().fx) * n.disparity_step_px;
      ++valid;
      within += noisy.distanceToSurface(p_world) < 4.0 * sigma + step;
    }
  }
  EXPECT_GT(valid, 0.85 * f.depth.total() / 4);  // holes at edges, grazing angles, far range
  EXPECT_GT(within, 0.99 * valid);
}

TEST(SynthTrajectory, LoopReturnsExactlyToItsStart) {
  for (int frames : {2, 3, 10, 300, 1000}) {
    SynthConfig c;
    c.frames = frames;
    const auto t = makeSynthTrajectory(c);
    ASSERT_TRUE(t) << t.error();
    ASSERT_EQ(t->size(), static_cast<size_t>(frames));
    EXPECT_TRUE(t->front().T_world_cam.isApprox(t->back().T_world_cam, 1e-12)) << frames;
  }
  // The loop turns a full circle: heading of the optical axis at a quarter of the way is ~90 degrees.
  const auto t = makeSynthTrajectory(SynthConfig{});
  const Vec3 z0 = t->front().T_world_cam.linear().col(2), z1 = (*t)[75].T_world_cam.linear().col(2);
  EXPECT_NEAR(std::atan2(z0.x() * z1.y() - z0.y() * z1.x(), z0.x() * z1.x() + z0.y() * z1.y()), M_PI / 2,
              0.3);
}

TEST(SynthTrajectory, MotionIsSmoothAndRealistic) {
  for (const char* name : {"loop", "sweep"}) {
    SynthConfig c;
    c.scene = name;
    const Trajectory t = makeSynthTrajectory(c).value();
    const double dt = 1.0 / c.fps;
    double max_speed = 0.0, max_rate = 0.0, max_accel = 0.0;
    for (size_t i = 1; i < t.size(); ++i) {
      const SE3 delta = t[i - 1].T_world_cam.inverse() * t[i].T_world_cam;
      max_speed = std::max(max_speed, delta.translation().norm() / dt);
      max_rate = std::max(max_rate, se3::rotationAngle(delta) / dt);
      EXPECT_NEAR(t[i].timestamp - t[i - 1].timestamp, dt, 1e-9);
      if (i + 1 < t.size()) {
        const Vec3 accel = (t[i + 1].T_world_cam.translation() - 2 * t[i].T_world_cam.translation() +
                            t[i - 1].T_world_cam.translation()) /
                           (dt * dt);
        max_accel = std::max(max_accel, accel.norm());
      }
    }
    EXPECT_LT(max_speed, 0.7) << name;         // m/s, handheld
    EXPECT_LT(max_rate, 60.0 * kDeg) << name;  // rad/s
    EXPECT_LT(max_accel, 1.0) << name;         // m/s^2, no jumps
    EXPECT_GT(max_speed, 0.05) << name;
  }
}

TEST(SynthTrajectory, CameraNeverGetsCloserThanHalfAMetreToASurface) {
  for (const char* name : {"loop", "sweep"}) {
    SynthConfig c = exactConfig(name);
    const SyntheticScene& s = scene(c);
    const CameraIntrinsics& k = s.config().camera;
    double nearest = 1e9;
    for (const StampedPose& pose : s.trajectory())
      for (int y = 0; y < k.height; y += 40)
        for (int x = 0; x < k.width; x += 40) {
          const auto hit = s.castRay(pose.T_world_cam.translation(), pixelRay(pose.T_world_cam, k, x, y));
          ASSERT_TRUE(hit);
          nearest = std::min(nearest, hit->t);  // the ray's camera z is 1, so t is the depth
        }
    EXPECT_GT(nearest, 0.5) << name;
  }
}

TEST(SynthScene, OrbFindsPlentyOfKeypointsWithDepth) {
  const auto orb = cv::ORB::create(1000);
  for (const char* name : {"loop", "sweep"}) {
    SynthConfig c;
    c.scene = name;
    const SyntheticScene& s = scene(c);
    for (int i : {0, 75, 150, 225, 299}) {
      const RgbdFrame f = s.renderFrame(i);
      cv::Mat grey;
      cv::cvtColor(f.color, grey, cv::COLOR_BGR2GRAY);
      std::vector<cv::KeyPoint> keypoints;
      orb->detect(grey, keypoints);
      int with_depth = 0;
      for (const auto& kp : keypoints)
        with_depth += f.depthMetres(static_cast<int>(kp.pt.x + 0.5f), static_cast<int>(kp.pt.y + 0.5f)) > 0;
      EXPECT_GT(with_depth, 500) << name << " frame " << i << " (" << keypoints.size() << " keypoints)";
    }
  }
}

TEST(SynthScene, OrbMatchesBetweenFramesAgreeWithTheGroundTruthMotion) {
  const SyntheticScene& s = scene(SynthConfig{});
  const PinholeCamera cam(s.config().camera);
  const auto orb = cv::ORB::create(1000);
  for (const auto& [from, to] : {std::pair<int, int>{100, 101}, {200, 210}}) {
    const RgbdFrame a = s.renderFrame(from), b = s.renderFrame(to);
    std::vector<cv::KeyPoint> ka, kb;
    cv::Mat grey_a, grey_b, desc_a, desc_b;
    cv::cvtColor(a.color, grey_a, cv::COLOR_BGR2GRAY);
    cv::cvtColor(b.color, grey_b, cv::COLOR_BGR2GRAY);
    orb->detectAndCompute(grey_a, cv::noArray(), ka, desc_a);
    orb->detectAndCompute(grey_b, cv::noArray(), kb, desc_b);
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher(cv::NORM_HAMMING).knnMatch(desc_a, desc_b, knn, 2);
    const SE3 T_b_a = s.trajectory()[static_cast<size_t>(to)].T_world_cam.inverse() *
                      s.trajectory()[static_cast<size_t>(from)].T_world_cam;
    int matches = 0, consistent = 0;
    for (const auto& m : knn) {
      if (m.size() < 2 || m[0].distance > 0.8f * m[1].distance) continue;
      const cv::Point2f pa = ka[static_cast<size_t>(m[0].queryIdx)].pt,
                        pb = kb[static_cast<size_t>(m[0].trainIdx)].pt;
      const double z = a.depthMetres(static_cast<int>(pa.x + 0.5f), static_cast<int>(pa.y + 0.5f));
      if (z <= 0.0) continue;
      ++matches;
      const auto px_b = cam.project(T_b_a * cam.backProject(Eigen::Vector2d(pa.x, pa.y), z));
      consistent += px_b && (*px_b - Eigen::Vector2d(pb.x, pb.y)).norm() < 3.0;
    }
    EXPECT_GT(consistent, 250) << from << " -> " << to;
    EXPECT_GT(consistent, 0.85 * matches) << from << " -> " << to;
  }
}

class SynthWriter : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("rgbdmap_synth_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

std::string readFile(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::vector<std::string> listLines(const fs::path& p) {
  std::vector<std::string> lines;
  std::istringstream in(readFile(p));
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') lines.push_back(line);
  return lines;
}

TEST_F(SynthWriter, WritesATumSequenceThatReadsBackExactly) {
  SynthConfig c;
  c.scene = "sweep";
  c.frames = 5;
  ASSERT_TRUE(writeSyntheticSequence(c, dir_.string()));
  const auto rgb = listLines(dir_ / "rgb.txt"), depth = listLines(dir_ / "depth.txt");
  ASSERT_EQ(rgb.size(), 5u);
  ASSERT_EQ(depth.size(), 5u);
  EXPECT_EQ(rgb[1], "1000.033333 rgb/1000.033333.png");
  EXPECT_EQ(depth[1], "1000.033833 depth/1000.033833.png");
  const auto gt = readTumTrajectory((dir_ / "groundtruth.txt").string());
  ASSERT_TRUE(gt) << gt.error();
  const SyntheticScene& s = scene(c);
  ASSERT_EQ(gt->size(), 5u);
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_NEAR((*gt)[i].timestamp, s.trajectory()[i].timestamp, 1e-6);
    EXPECT_LT(((*gt)[i].T_world_cam.matrix() - s.trajectory()[i].T_world_cam.matrix()).norm(), 1e-6);
  }
  const YAML::Node cam = YAML::LoadFile((dir_ / "camera.yaml").string())["camera"];
  EXPECT_EQ(cam["fx"].as<double>(), 525.0);
  EXPECT_EQ(cam["cy"].as<double>(), 239.5);
  EXPECT_EQ(cam["width"].as<int>(), 640);
  EXPECT_EQ(cam["depth_scale"].as<double>(), 5000.0);
  EXPECT_EQ(cam["readout_s"].as<double>(), 0.0) << "the renderer has a global shutter";
  ASSERT_EQ(cam["distortion"].size(), 5u);
  for (const auto& d : cam["distortion"]) EXPECT_EQ(d.as<double>(), 0.0);
  // PNGs are lossless: they read back as the in-memory rendering.
  const RgbdFrame f = s.renderFrame(3);
  EXPECT_TRUE(sameImage(
      cv::imread((dir_ / rgb[3].substr(rgb[3].find(' ') + 1)).string(), cv::IMREAD_UNCHANGED), f.color));
  EXPECT_TRUE(sameImage(
      cv::imread((dir_ / depth[3].substr(depth[3].find(' ') + 1)).string(), cv::IMREAD_UNCHANGED), f.depth));
}

TEST_F(SynthWriter, SameSeedGivesByteIdenticalFiles) {
  SynthConfig c;
  c.frames = 3;
  ASSERT_TRUE(writeSyntheticSequence(c, (dir_ / "a").string()));
  ASSERT_TRUE(writeSyntheticSequence(c, (dir_ / "b").string()));
  int compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir_ / "a")) {
    if (!entry.is_regular_file()) continue;
    const fs::path twin = dir_ / "b" / fs::relative(entry.path(), dir_ / "a");
    EXPECT_EQ(readFile(entry.path()), readFile(twin)) << twin;
    ++compared;
  }
  EXPECT_EQ(compared, 3 * 2 + 4);
}

TEST_F(SynthWriter, ReportsUnwritableDirectoriesAndBadConfigs) {
  std::ofstream(dir_.string() + "_file") << "x";  // a file where a folder is wanted
  const Status s = writeSyntheticSequence(SynthConfig{}, dir_.string() + "_file/seq");
  fs::remove(dir_.string() + "_file");
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().find("cannot create"), std::string::npos) << s.error();
  SynthConfig bad;
  bad.frames = 0;
  EXPECT_FALSE(writeSyntheticSequence(bad, dir_.string()));
  EXPECT_FALSE(fs::exists(dir_));
}

}  // namespace
}  // namespace rgbdmap
