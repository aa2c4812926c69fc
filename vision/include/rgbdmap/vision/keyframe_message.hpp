#pragma once
// The one conversion between the client's Keyframe (odometry.hpp) and the wire message msg::Keyframe, and
// back from a received message to the features the server's loop closure works on.
#include <string>

#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/vision/features.hpp"
#include "rgbdmap/vision/keyframe.hpp"

namespace rgbdmap {

/// Builds the message of a keyframe (header left default: msg::Signer::seal stamps it). Keypoints beyond
/// msg::kMaxKeypoints are refused rather than cut; a non-positive-semidefinite or non-finite information is
/// sent as zero (the server then uses its default odometry uncertainty). Without `with_features` the
/// message carries no keypoints and no descriptors: the server extracts them from the decoded colour
/// (extractServerFeatures), which needs colour in the images.
Result<msg::Keyframe> keyframeToMessage(const Keyframe& keyframe, const std::string& robot_id,
                                        EncodedImages images, bool with_features = true);

/// Writes `features` into the message's keypoints and descriptors, replacing what it had. Fails on more
/// than msg::kMaxKeypoints keypoints or descriptors that do not match them.
Status putFeatures(const FrameFeatures& features, msg::Keyframe* message);

/// True for a keyframe whose features the server must extract: no keypoints, colour present.
bool needsServerFeatures(const msg::Keyframe& keyframe);

/// The features of a keyframe sent without them, extracted by `extractor` (configured as the robot's
/// odometry is) from its decoded colour and depth, with depth in metres through camera.depth_scale.
FrameFeatures extractServerFeatures(const OrbExtractor& extractor, const DecodedImages& images,
                                    const CameraIntrinsics& camera);

/// Features of a received keyframe: keypoints and descriptors as sent, undistorted pixels through `camera`
/// (the sender's intrinsics from its Hello), depth as sent and the back-projected 3-D points, exactly as
/// OrbExtractor computes them on the robot. Fails when the descriptor bytes do not match the keypoints.
Result<FrameFeatures> featuresFromMessage(const msg::Keyframe& keyframe, const PinholeCamera& camera);

}  // namespace rgbdmap
