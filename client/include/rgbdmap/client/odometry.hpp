#pragma once
// Frame-to-keyframe RGB-D visual odometry: ORB features, brute-force matching with outlier filters,
// 3-D RANSAC, robust refinement, keyframes by similarity, loss detection and relocalisation.
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "rgbdmap/client/odometry_config.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/rgbd_frame.hpp"
#include "rgbdmap/vision/features.hpp"
#include "rgbdmap/vision/keyframe.hpp"
#include "rgbdmap/vision/ransac.hpp"

namespace rgbdmap {

enum class TrackingState {
  kInitialized,  ///< first keyframe of a segment was created
  kTracking,     ///< tracked against the reference keyframe
  kRelocalized,  ///< tracked against an older keyframe after the reference failed
  kLost,         ///< not tracked; the pose is the motion-model prediction
};
const char* toString(TrackingState state);

struct StageTimes {
  double extract_ms = 0, match_ms = 0, ransac_ms = 0, refine_ms = 0, total_ms = 0;
};

struct TrackingResult {
  int frame_index = 0;
  double timestamp = 0.0;
  SE3 T_odom_cam = SE3::Identity();
  TrackingState state = TrackingState::kLost;
  int segment = 0;
  int reference_keyframe = -1;
  int features = 0, matches = 0, inliers = 0;
  double similarity = 0.0;
  std::shared_ptr<const Keyframe> new_keyframe;  ///< set when this frame became a keyframe
  std::string keyframe_reason;
  StageTimes times;
};

class VisualOdometry {
 public:
  /// Keyframe ids start at first_keyframe_id and segments at first_segment (a robot resuming the session
  /// of its keyframe spool continues above the numbers that session used).
  VisualOdometry(const CameraIntrinsics& intrinsics, const OdometryConfig& config, int first_keyframe_id = 0,
                 int first_segment = 0);

  TrackingResult track(const RgbdFrame& frame);

  const std::vector<std::shared_ptr<const Keyframe>>& keyframes() const { return keyframes_; }
  int trackingLosses() const { return losses_; }
  const PinholeCamera& camera() const { return camera_; }

 private:
  struct Estimate {
    bool ok = false;
    SE3 T_cur_kf = SE3::Identity();
    int matches = 0, inliers = 0;
    Mat6 information = Mat6::Zero();
    std::vector<PointMatch> inlier_matches;  ///< refined inliers, points in the keyframe's camera frame
  };
  Estimate estimateAgainst(const Keyframe& kf, const FrameFeatures& cur, const SE3& T_cur_kf_prior,
                           StageTimes* times) const;
  /// Adds matches against the keyframes before the reference (same segment) and refines T_cur_ref on all
  /// of them jointly, so a new keyframe's pose averages several keyframes instead of chaining one.
  std::vector<const Keyframe*> selectWindow(const SE3& T_odom_cur) const;
  void refineInWindow(const FrameFeatures& cur, Estimate* est, StageTimes* times) const;
  bool relocalize(const FrameFeatures& cur, const SE3& T_odom_pred, TrackingResult* result, Estimate* est,
                  StageTimes* times);
  std::shared_ptr<Keyframe> makeKeyframe(FrameFeatures features, const TrackingResult& r) const;
  void handleLoss(FrameFeatures features, TrackingResult* result);
  SE3 predictPose() const;

  PinholeCamera camera_;
  OdometryConfig config_;
  OrbExtractor extractor_;
  std::vector<std::shared_ptr<const Keyframe>> keyframes_;
  std::shared_ptr<const Keyframe> reference_;
  SE3 T_odom_last_ = SE3::Identity();
  SE3 velocity_ = SE3::Identity();  ///< T_last_prev^-1 style constant-velocity model: T_prev_last
  int frame_index_ = 0;
  int frames_since_keyframe_ = 0;
  int consecutive_lost_ = 0;
  int losses_ = 0;
  int first_keyframe_id_ = 0;
  int segment_ = 0;
};

}  // namespace rgbdmap
