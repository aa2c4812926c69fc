#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "test_cameras.hpp"

#include "rgbdmap/vision/guided_matcher.hpp"

namespace rgbdmap {
namespace {

void addFeature(FrameFeatures* f, const Eigen::Vector2d& px, double depth, const PinholeCamera& cam,
                const cv::Mat& descriptor) {
  f->keypoints.emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()), 31.f, -1.f, 0.f, 0);
  f->px.push_back(px);
  f->depth_m.push_back(depth);
  f->p_cam.push_back(depth > 0 ? cam.backProject(px, depth) : Vec3::Zero());
  f->descriptors.push_back(descriptor);
}

TEST(FeatureGrid, QueryEqualsBruteForce) {
  const PinholeCamera cam(testing::idealPinhole());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 640), v(0, 480);
  FrameFeatures f;
  for (int i = 0; i < 500; ++i) addFeature(&f, {u(rng), v(rng)}, 0, cam, cv::Mat::zeros(1, 32, CV_8U));
  const FeatureGrid grid(f, 640, 480);
  std::vector<int> got;
  for (int q = 0; q < 50; ++q) {
    const double x = u(rng), y = v(rng), r = 5 + q;
    grid.query(x, y, r, &got);
    std::vector<int> want;
    for (int i = 0; i < 500; ++i)
      if ((f.px[i] - Eigen::Vector2d(x, y)).norm() <= r) want.push_back(i);
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, want) << "query " << q;
  }
}

TEST(GuidedMatcher, FindsProjectedCorrespondencesAmongDistractors) {
  const PinholeCamera cam(testing::idealPinhole());
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(20, 620), v(20, 460), z(1.0, 3.0);
  std::uniform_int_distribution<int> byte(0, 255);
  Vec6 xi;
  xi << 0.05, -0.02, 0.03, 0.02, -0.03, 0.01;
  const SE3 T_cur_kf = se3::exp(xi);
  FrameFeatures kf, cur;
  std::vector<int> truth;  // kf index -> cur index
  for (int i = 0; i < 300; ++i) {
    cv::Mat d(1, 32, CV_8U);
    for (int c = 0; c < 32; ++c) d.at<uint8_t>(0, c) = static_cast<uint8_t>(byte(rng));
    const Eigen::Vector2d px(u(rng), v(rng));
    const double depth = z(rng);
    addFeature(&kf, px, depth, cam, d);
    const auto px_cur = cam.project(T_cur_kf * cam.backProject(px, depth));
    if (!px_cur || !cam.inImage(*px_cur)) {
      truth.push_back(-1);
      continue;
    }
    cv::Mat noisy = d.clone();
    noisy.at<uint8_t>(0, 3) ^= 0x5;  // 2 flipped bits
    truth.push_back(static_cast<int>(cur.size()));
    addFeature(&cur, *px_cur + Eigen::Vector2d(1.0, -0.5), 0, cam, noisy);
    cv::Mat other(1, 32, CV_8U);  // a distractor nearby with an unrelated descriptor
    for (int c = 0; c < 32; ++c) other.at<uint8_t>(0, c) = static_cast<uint8_t>(byte(rng));
    addFeature(&cur, *px_cur + Eigen::Vector2d(4.0, 3.0), 0, cam, other);
  }
  const FeatureGrid grid(cur, 640, 480);
  const auto matches = matchByProjection(cur, grid, kf, T_cur_kf, cam, GuidedMatchConfig{});
  int correct = 0;
  for (const auto& m : matches) correct += truth[m.train] == m.query;
  EXPECT_EQ(correct, static_cast<int>(matches.size())) << "every match is the true one";
  EXPECT_GT(matches.size(), 250u);
  // With a pose far off, nothing lands near the right keypoints: no confident matches.
  Vec6 off;
  off << 0.5, 0, 0, 0, 0.3, 0;
  const auto wrong = matchByProjection(cur, grid, kf, se3::exp(off) * T_cur_kf, cam, GuidedMatchConfig{});
  EXPECT_LT(wrong.size(), 10u);
}

}  // namespace
}  // namespace rgbdmap
