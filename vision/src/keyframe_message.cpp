#include "rgbdmap/vision/keyframe_message.hpp"

#include <cmath>
#include <cstring>

#include <Eigen/Eigenvalues>

namespace rgbdmap {
namespace {

bool isUsableInformation(const Mat6& info) {
  if (!info.allFinite() || !info.isApprox(info.transpose(), 1e-9 * (1.0 + info.norm()))) return false;
  const Eigen::SelfAdjointEigenSolver<Mat6> eig(0.5 * (info + info.transpose()));
  return eig.info() == Eigen::Success && eig.eigenvalues().minCoeff() >= 0.0;
}

}  // namespace

Status putFeatures(const FrameFeatures& f, msg::Keyframe* m) {
  const size_t n = f.size();
  if (n > static_cast<size_t>(msg::kMaxKeypoints))
    return Status::failure(std::to_string(n) + " keypoints, more than the message allows");
  if (n > 0 && (f.descriptors.rows != static_cast<int>(n) || f.descriptors.cols != msg::kDescriptorBytes ||
                f.descriptors.type() != CV_8U))
    return Status::failure("descriptors that do not match its " + std::to_string(n) + " keypoints");
  if (f.depth_m.size() != n) return Status::failure("a depth array that does not match its keypoints");
  m->keypoints.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::KeyPoint& k = f.keypoints[i];
    msg::KeyPoint& out = m->keypoints[i];
    out.u = k.pt.x;
    out.v = k.pt.y;
    out.octave = k.octave;
    out.angle_deg = k.angle;
    out.response = k.response;
    out.depth_m = static_cast<float>(f.depth_m[i]);
  }
  m->descriptors.resize(n * msg::kDescriptorBytes);
  for (size_t i = 0; i < n; ++i)
    std::memcpy(m->descriptors.data() + i * msg::kDescriptorBytes,
                f.descriptors.ptr<uint8_t>(static_cast<int>(i)), msg::kDescriptorBytes);
  return Status::success();
}

Result<msg::Keyframe> keyframeToMessage(const Keyframe& keyframe, const std::string& robot_id,
                                        EncodedImages images, bool with_features) {
  using R = Result<msg::Keyframe>;
  msg::Keyframe m;
  m.robot_id = robot_id;
  m.segment_id = keyframe.segment;
  m.keyframe_id = keyframe.id;
  m.timestamp = keyframe.timestamp;
  m.T_odom_cam = keyframe.T_odom_cam;
  m.previous_keyframe_id = keyframe.previous_id;
  m.T_prev_cur = keyframe.T_prev_cur;
  m.information = isUsableInformation(keyframe.information) ? keyframe.information : Mat6::Zero();
  if (with_features) {
    if (const Status s = putFeatures(keyframe.features, &m); !s)
      return R::failure("keyframe " + std::to_string(keyframe.id) + " has " + s.error());
  } else if (images.color_codec == ColorCodec::kNone) {
    return R::failure("keyframe " + std::to_string(keyframe.id) +
                      ": without features the server needs the colour image to extract them");
  }
  m.images = std::move(images);
  return m;
}

bool needsServerFeatures(const msg::Keyframe& keyframe) {
  return keyframe.keypoints.empty() && keyframe.images.color_codec != ColorCodec::kNone;
}

FrameFeatures extractServerFeatures(const OrbExtractor& extractor, const DecodedImages& images,
                                    const CameraIntrinsics& camera) {
  RgbdFrame frame;
  frame.color = images.color;
  frame.depth = images.depth;
  frame.depth_scale = camera.depth_scale;
  return extractor.extract(frame, PinholeCamera(camera));
}

Result<FrameFeatures> featuresFromMessage(const msg::Keyframe& keyframe, const PinholeCamera& camera) {
  using R = Result<FrameFeatures>;
  const size_t n = keyframe.keypoints.size();
  if (keyframe.descriptors.size() != n * msg::kDescriptorBytes)
    return R::failure("keyframe " + std::to_string(keyframe.keyframe_id) + ": " +
                      std::to_string(keyframe.descriptors.size()) + " descriptor bytes for " +
                      std::to_string(n) + " keypoints");
  FrameFeatures f;
  f.keypoints.resize(n);
  f.px.resize(n);
  f.depth_m.resize(n);
  f.p_cam.resize(n);
  f.descriptors.create(static_cast<int>(n), msg::kDescriptorBytes, CV_8U);
  for (size_t i = 0; i < n; ++i) {
    const msg::KeyPoint& k = keyframe.keypoints[i];
    if (!std::isfinite(k.u) || !std::isfinite(k.v) || !std::isfinite(k.depth_m) || k.depth_m < 0.0f)
      return R::failure("keyframe " + std::to_string(keyframe.keyframe_id) + ": keypoint " +
                        std::to_string(i) + " is not finite");
    f.keypoints[i] = cv::KeyPoint(k.u, k.v, 31.0f, k.angle_deg, k.response, k.octave);
    f.px[i] = camera.undistort(Eigen::Vector2d(k.u, k.v));
    f.depth_m[i] = k.depth_m;
    f.p_cam[i] = k.depth_m > 0.0f ? camera.backProject(f.px[i], k.depth_m) : Vec3::Zero();
    std::memcpy(f.descriptors.ptr<uint8_t>(static_cast<int>(i)),
                keyframe.descriptors.data() + i * msg::kDescriptorBytes, msg::kDescriptorBytes);
  }
  return f;
}

}  // namespace rgbdmap
