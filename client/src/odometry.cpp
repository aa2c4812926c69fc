#include "rgbdmap/client/odometry.hpp"

#include <chrono>

#include "rgbdmap/client/keyframe_selector.hpp"
#include "rgbdmap/client/matcher.hpp"
#include "rgbdmap/client/pose_refiner.hpp"
#include "rgbdmap/client/ransac.hpp"

namespace rgbdmap {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Correspondences between the current frame and a keyframe's features with depth.
std::vector<PointMatch> buildPointMatches(const FrameFeatures& cur, const FrameFeatures& kf,
                                          const std::vector<FeatureMatch>& matches, float scale_factor) {
  std::vector<PointMatch> out;
  out.reserve(matches.size());
  for (const auto& m : matches) {
    PointMatch pm;
    pm.p_ref = kf.p_cam[m.train];
    pm.p_cur = cur.hasDepth(m.query) ? cur.p_cam[m.query] : Vec3::Zero();
    pm.px_cur = cur.px[m.query];
    pm.px_ref = kf.px[m.train];
    pm.sigma_px = std::pow(scale_factor, cur.keypoints[m.query].octave);
    out.push_back(pm);
  }
  return out;
}

}  // namespace

const char* toString(TrackingState state) {
  switch (state) {
    case TrackingState::kInitialized:
      return "initialized";
    case TrackingState::kTracking:
      return "tracking";
    case TrackingState::kRelocalized:
      return "relocalized";
    default:
      return "lost";
  }
}

VisualOdometry::VisualOdometry(const CameraIntrinsics& intrinsics, const OdometryConfig& config)
    : camera_(intrinsics), config_(config), extractor_(config.orb) {}

SE3 VisualOdometry::predictPose() const { return T_odom_last_ * velocity_; }

VisualOdometry::Estimate VisualOdometry::estimateAgainst(const Keyframe& kf, const FrameFeatures& cur,
                                                         const SE3& T_cur_kf_prior, StageTimes* times) const {
  Estimate est;
  auto t0 = Clock::now();
  std::vector<char> mask(kf.features.size());
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = kf.features.hasDepth(i);
  const auto matches = matchDescriptors(cur.descriptors, kf.features.descriptors, config_.matcher, &mask);
  const auto point_matches = buildPointMatches(cur, kf.features, matches, config_.orb.scale_factor);
  est.matches = static_cast<int>(matches.size());
  times->match_ms += msSince(t0);

  t0 = Clock::now();
  const RansacResult ransac = ransacRigid(point_matches, camera_, config_.ransac);
  times->ransac_ms += msSince(t0);

  t0 = Clock::now();
  // Without a RANSAC consensus the motion prior seeds the refinement; the chi2 re-classification and the
  // inlier count below decide whether that start was good enough.
  const RefineResult refined =
      refinePose(point_matches, ransac.success ? ransac.T_cur_ref : T_cur_kf_prior, camera_, config_.refine);
  times->refine_ms += msSince(t0);
  est.inliers = refined.inliers;
  est.T_cur_kf = refined.T_cur_ref;
  est.information = refined.information;
  est.ok = refined.inliers >= config_.min_tracking_inliers && se3::isValid(refined.T_cur_ref, 1e-4);
  return est;
}

void VisualOdometry::refineInWindow(const FrameFeatures& cur, Estimate* est, StageTimes* times) const {
  std::vector<PointMatch> all;
  const SE3 T_ref_odom = reference_->T_odom_cam.inverse();
  int used = 0;
  for (auto it = keyframes_.rbegin(); it != keyframes_.rend() && used < config_.window_keyframes; ++it) {
    const Keyframe& kf = **it;
    if (kf.segment != reference_->segment) break;
    ++used;
    auto t0 = Clock::now();
    std::vector<char> mask(kf.features.size());
    for (size_t i = 0; i < mask.size(); ++i) mask[i] = kf.features.hasDepth(i);
    const auto matches = matchDescriptors(cur.descriptors, kf.features.descriptors, config_.matcher, &mask);
    auto pms = buildPointMatches(cur, kf.features, matches, config_.orb.scale_factor);
    times->match_ms += msSince(t0);
    // Express the keyframe's points in the reference keyframe so one refinement covers the window.
    const SE3 T_ref_kf = T_ref_odom * kf.T_odom_cam;
    RansacConfig gate = config_.ransac;
    gate.reprojection_threshold_px *= 2.0;
    for (auto& pm : pms) {
      pm.p_ref = T_ref_kf * pm.p_ref;
      if (isGeometricInlier(pm, est->T_cur_kf, camera_, gate)) all.push_back(pm);
    }
  }
  if (used < 2) return;
  const auto t0 = Clock::now();
  const RefineResult refined = refinePose(all, est->T_cur_kf, camera_, config_.refine);
  times->refine_ms += msSince(t0);
  if (refined.inliers >= est->inliers && se3::isValid(refined.T_cur_ref, 1e-4)) {
    est->T_cur_kf = refined.T_cur_ref;
    est->information = refined.information;
  }
}

bool VisualOdometry::relocalize(const FrameFeatures& cur, const SE3& T_odom_pred, TrackingResult* result,
                                Estimate* est, StageTimes* times) {
  const int n = static_cast<int>(keyframes_.size());
  Estimate best;
  std::shared_ptr<const Keyframe> best_kf;
  for (int i = n - 1, tried = 0; i >= 0 && tried < config_.relocalization_keyframes; --i) {
    const auto& kf = keyframes_[i];
    if (kf == reference_) continue;
    ++tried;
    Estimate e = estimateAgainst(*kf, cur, T_odom_pred.inverse() * kf->T_odom_cam, times);
    if (e.ok && e.inliers > best.inliers) {
      best = e;
      best_kf = kf;
    }
  }
  if (!best_kf) return false;
  reference_ = best_kf;
  segment_ = best_kf->segment;
  frames_since_keyframe_ = 0;
  *est = best;
  result->state = TrackingState::kRelocalized;
  return true;
}

std::shared_ptr<Keyframe> VisualOdometry::makeKeyframe(FrameFeatures features,
                                                       const TrackingResult& r) const {
  auto kf = std::make_shared<Keyframe>();
  kf->id = static_cast<int>(keyframes_.size());
  kf->segment = r.segment;
  kf->frame_index = r.frame_index;
  kf->timestamp = r.timestamp;
  kf->T_odom_cam = r.T_odom_cam;
  kf->features = std::move(features);
  return kf;
}

void VisualOdometry::handleLoss(FrameFeatures features, TrackingResult* r) {
  ++losses_;
  ++consecutive_lost_;
  r->state = TrackingState::kLost;
  r->T_odom_cam = predictPose();
  const bool can_restart = static_cast<int>(features.countWithDepth()) >= config_.min_keyframe_points;
  if (consecutive_lost_ > config_.max_lost_frames && can_restart) {
    // Give up on relocalisation: a new segment starts here, flagged as a discontinuity.
    ++segment_;
    r->segment = segment_;
    auto kf = makeKeyframe(std::move(features), *r);
    keyframes_.push_back(kf);
    reference_ = kf;
    r->new_keyframe = kf;
    r->keyframe_reason = "new_segment";
    r->state = TrackingState::kInitialized;
    consecutive_lost_ = 0;
    frames_since_keyframe_ = 0;
    velocity_ = SE3::Identity();
  }
  T_odom_last_ = r->T_odom_cam;
}

TrackingResult VisualOdometry::track(const RgbdFrame& frame) {
  const auto t_start = Clock::now();
  TrackingResult r;
  r.frame_index = frame_index_++;
  r.timestamp = frame.timestamp;
  auto t0 = Clock::now();
  FrameFeatures cur = extractor_.extract(frame, camera_);
  r.times.extract_ms = msSince(t0);
  r.features = static_cast<int>(cur.size());
  r.segment = segment_;

  if (!reference_) {
    r.T_odom_cam = T_odom_last_;
    if (static_cast<int>(cur.countWithDepth()) < config_.min_keyframe_points) {
      r.state = TrackingState::kLost;
      ++losses_;
    } else {
      auto kf = makeKeyframe(std::move(cur), r);
      keyframes_.push_back(kf);
      reference_ = kf;
      r.new_keyframe = kf;
      r.keyframe_reason = "first";
      r.state = TrackingState::kInitialized;
      r.reference_keyframe = kf->id;
    }
    r.times.total_ms = msSince(t_start);
    return r;
  }

  const SE3 T_odom_pred = predictPose();
  Estimate est = estimateAgainst(*reference_, cur, T_odom_pred.inverse() * reference_->T_odom_cam, &r.times);
  r.state = TrackingState::kTracking;
  if (!est.ok && !relocalize(cur, T_odom_pred, &r, &est, &r.times)) {
    r.matches = est.matches;
    r.inliers = est.inliers;
    handleLoss(std::move(cur), &r);
    r.reference_keyframe = reference_->id;
    r.times.total_ms = msSince(t_start);
    return r;
  }
  if (config_.window_keyframes > 1) refineInWindow(cur, &est, &r.times);
  consecutive_lost_ = 0;
  r.segment = segment_;
  r.matches = est.matches;
  r.inliers = est.inliers;
  r.reference_keyframe = reference_->id;
  r.T_odom_cam = se3::normalized(reference_->T_odom_cam * est.T_cur_kf.inverse());
  velocity_ = T_odom_last_.inverse() * r.T_odom_cam;
  T_odom_last_ = r.T_odom_cam;
  ++frames_since_keyframe_;

  const KeyframeDecision d =
      decideKeyframe(est.matches, r.features, static_cast<int>(reference_->features.size()),
                     frames_since_keyframe_, est.T_cur_kf.inverse(), config_.keyframe);
  r.similarity = d.similarity;
  if (d.new_keyframe && static_cast<int>(cur.countWithDepth()) >= config_.min_keyframe_points) {
    auto kf = makeKeyframe(std::move(cur), r);
    kf->previous_id = reference_->id;
    kf->T_prev_cur = est.T_cur_kf.inverse();
    kf->information = est.information;
    keyframes_.push_back(kf);
    reference_ = kf;
    r.new_keyframe = kf;
    r.keyframe_reason = d.reason;
    frames_since_keyframe_ = 0;
  }
  r.times.total_ms = msSince(t_start);
  return r;
}

}  // namespace rgbdmap
