#pragma once
// The one conversion between the client's Keyframe (odometry.hpp) and the wire message msg::Keyframe, and
// back from a received message to the features the server's loop closure works on.
#include <string>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/image_codec.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/vision/features.hpp"
#include "rgbdmap/vision/keyframe.hpp"

namespace rgbdmap {

/// Builds the message of a keyframe (header left default: msg::Signer::seal stamps it). Keypoints beyond
/// msg::kMaxKeypoints are refused rather than cut; a non-positive-semidefinite or non-finite information is
/// sent as zero (the server then uses its default odometry uncertainty).
Result<msg::Keyframe> keyframeToMessage(const Keyframe& keyframe, const std::string& robot_id,
                                        EncodedImages images);

/// Features of a received keyframe: keypoints and descriptors as sent, undistorted pixels through `camera`
/// (the sender's intrinsics from its Hello), depth as sent and the back-projected 3-D points, exactly as
/// OrbExtractor computes them on the robot. Fails when the descriptor bytes do not match the keypoints.
Result<FrameFeatures> featuresFromMessage(const msg::Keyframe& keyframe, const PinholeCamera& camera);

}  // namespace rgbdmap
