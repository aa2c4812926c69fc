// Validation of the robot's messages: Hello, Heartbeat, RobotPose, LinkStatus, Keyframe.
#include <cmath>
#include <cstring>

#include <Eigen/Eigenvalues>

#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap::msg {
namespace {

Status fail(const char* reason) { return Status::failure(reason); }

Status validateKeypoints(const Keyframe& m) {
  if (m.keypoints.size() > static_cast<size_t>(kMaxKeypoints)) return fail("too many keypoints");
  if (m.descriptors.size() != m.keypoints.size() * kDescriptorBytes)
    return fail("descriptor bytes != keypoints * 32");
  const float w = m.images.width, h = m.images.height;
  for (const KeyPoint& k : m.keypoints) {
    if (!(k.u >= 0.0f && k.u < w && k.v >= 0.0f && k.v < h)) return fail("keypoint outside the image");
    if (k.octave < 0 || k.octave > 31) return fail("keypoint octave out of range");
    if (!(k.angle_deg >= -1.0f && k.angle_deg <= 360.0f)) return fail("keypoint angle out of range");
    if (!std::isfinite(k.response)) return fail("keypoint response not finite");
    if (!(k.depth_m >= 0.0f && k.depth_m <= 100.0f)) return fail("keypoint depth out of range");
  }
  return Status::success();
}

Status validateInformation(const Mat6& info) {
  if (!info.allFinite()) return fail("information not finite");
  const double scale = std::max(1.0, info.cwiseAbs().maxCoeff());
  if ((info - info.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    return fail("information not symmetric");
  const double min_eig = Eigen::SelfAdjointEigenSolver<Mat6>(info, Eigen::EigenvaluesOnly).eigenvalues()(0);
  if (min_eig < -1e-9 * scale) return fail("information not positive semi-definite");
  return Status::success();
}

/// The blob header of rgbdmap/codec/image_codec.hpp (magic at 0, width/height LE at 6 and 8) must match the
/// keyframe.
bool blobMatches(const Bytes& blob, const char* magic, int width, int height) {
  if (blob.size() < kImageBlobHeaderSize || std::memcmp(blob.data(), magic, 4) != 0) return false;
  return (blob[6] | blob[7] << 8) == width && (blob[8] | blob[9] << 8) == height;
}

Status validateImages(const EncodedImages& im) {
  const int w = im.width, h = im.height;
  if (w < 1 || h < 1 || w > kMaxImageSide || h > kMaxImageSide) return fail("image size out of range");
  const size_t slack = kImageBlobHeaderSize + 65536;  // zstd/JPEG overhead on incompressible content
  if (im.depth.size() > 2 * size_t(w) * h + slack) return fail("depth blob too large");
  if (!blobMatches(im.depth, "RDMD", w, h)) return fail("depth blob header does not match the image size");
  if (im.color_codec == ColorCodec::kNone) {
    if (!im.color.empty()) return fail("colour blob present with codec none");
    return Status::success();
  }
  if (im.color.size() > 3 * size_t(w) * h + slack) return fail("colour blob too large");
  if (!blobMatches(im.color, "RDMC", w, h)) return fail("colour blob header does not match the image size");
  return Status::success();
}

}  // namespace

Status validate(const Hello& m) {
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return fail("invalid robot id");
  if (m.header.sender != m.robot_id) return fail("sender is not the robot");
  if (std::string e = m.camera.validate(); !e.empty()) return Status::failure("camera: " + e);
  if (!isValidPose(m.T_base_camera)) return fail("invalid camera mount pose");
  if (!(m.T_base_camera.translation().norm() <= kMaxCameraOffsetM)) return fail("camera mount too far");
  if (!isValidText(m.software_version)) return fail("invalid software version text");
  if (m.capabilities.size() > static_cast<size_t>(kMaxCapabilities)) return fail("too many capabilities");
  for (const std::string& c : m.capabilities)
    if (!isValidId(c)) return fail("invalid capability name");
  return Status::success();
}

Status validate(const Heartbeat& m) {
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return fail("invalid robot id");
  if (m.header.sender != m.robot_id) return fail("sender is not the robot");
  if (m.last_keyframe_id < -1 || m.segment_id < 0) return fail("negative id");
  if (m.tracking_state < 0 || m.tracking_state > 3) return fail("tracking state out of range");
  if (!(std::isfinite(m.uptime_s) && m.uptime_s >= 0.0)) return fail("invalid uptime");
  return Status::success();
}

Status validate(const RobotPose& m) {
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return fail("invalid robot id");
  if (m.header.sender != m.robot_id) return fail("sender is not the robot");
  if (m.segment_id < 0 || m.reference_keyframe_id < -1 || m.graph_revision < -1) return fail("negative id");
  if (m.tracking_state < 0 || m.tracking_state > 3) return fail("tracking state out of range");
  if (!(std::isfinite(m.timestamp) && m.timestamp >= 0.0)) return fail("invalid timestamp");
  if (!isValidPose(m.T_map_cam)) return fail("invalid pose");
  return Status::success();
}

Status validate(const LinkStatus& m) {
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return fail("invalid robot id");
  if (m.header.sender != m.robot_id) return fail("sender is not the robot");
  if (m.keyframes_made < 0 || m.keyframes_acked < 0 || m.in_flight < 0 || m.queued < 0 ||
      m.spool_depth < -1 || m.spool_bytes < 0)
    return fail("negative count");
  if (!(std::isfinite(m.oldest_unanswered_s) && m.oldest_unanswered_s >= 0.0)) return fail("invalid age");
  if (!isValidText(m.diagnosis)) return fail("invalid diagnosis text");
  return Status::success();
}

Status validate(const Keyframe& m) {
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return fail("invalid robot id");
  if (m.header.sender != m.robot_id) return fail("sender is not the robot");
  if (m.segment_id < 0 || m.keyframe_id < 0 || m.previous_keyframe_id < -1) return fail("negative id");
  if (m.previous_keyframe_id >= m.keyframe_id) return fail("previous keyframe id not before keyframe id");
  if (!(std::isfinite(m.timestamp) && m.timestamp >= 0.0)) return fail("invalid timestamp");
  if (!isValidPose(m.T_odom_cam) || !isValidPose(m.T_prev_cur)) return fail("invalid pose");
  if (Status s = validateInformation(m.information); !s) return s;
  if (Status s = validateImages(m.images); !s) return s;
  return validateKeypoints(m);
}

}  // namespace rgbdmap::msg
