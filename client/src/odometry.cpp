#include "rgbdmap/client/odometry.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "rgbdmap/client/keyframe_selector.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/vision/guided_matcher.hpp"
#include "rgbdmap/vision/matcher.hpp"
#include "rgbdmap/vision/pose_refiner.hpp"
#include "rgbdmap/vision/ransac.hpp"

namespace rgbdmap {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
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

VisualOdometry::VisualOdometry(const CameraIntrinsics& intrinsics, const OdometryConfig& config,
                               int first_keyframe_id, int first_segment)
    : camera_(intrinsics),
      config_(config),
      extractor_(config.orb),
      first_keyframe_id_(first_keyframe_id),
      segment_(first_segment) {}

SE3 VisualOdometry::predictPose() const { return T_odom_last_ * velocity_; }

VisualOdometry::Estimate VisualOdometry::estimateAgainst(const Keyframe& kf, const FrameFeatures& cur,
                                                         const SE3& T_cur_kf_prior, StageTimes* times) const {
  Estimate est;
  auto t0 = Clock::now();
  std::vector<char> mask(kf.features.size());
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = kf.features.hasDepth(i);
  const auto matches = matchDescriptors(cur.descriptors, kf.features.descriptors, config_.matcher, &mask);
  const auto point_matches = toPointMatches(cur, kf.features, matches, config_.orb.scale_factor);
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
  for (size_t i = 0; i < point_matches.size(); ++i)
    if (refined.inlier_mask[i]) est.inlier_matches.push_back(point_matches[i]);
  est.ok = refined.inliers >= config_.min_tracking_inliers && se3::isValid(refined.T_cur_ref, 1e-4);
  return est;
}

std::vector<const Keyframe*> VisualOdometry::selectWindow(const SE3& T_odom_cur) const {
  // Keyframes that look the same way from nearby, most similar viewing direction first.
  std::vector<std::pair<double, const Keyframe*>> near;
  const Vec3 view_cur = T_odom_cur.linear().col(2);
  const double cos_max = std::cos(config_.window_max_angle_deg * M_PI / 180.0);
  for (const auto& kf : keyframes_) {
    if (kf == reference_ || kf->segment != reference_->segment) continue;
    const double cos_view = kf->T_odom_cam.linear().col(2).dot(view_cur);
    const double dist = (kf->T_odom_cam.translation() - T_odom_cur.translation()).norm();
    if (cos_view >= cos_max && dist <= config_.window_max_distance_m) near.push_back({-cos_view, kf.get()});
  }
  std::sort(near.begin(), near.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<const Keyframe*> out;
  for (size_t i = 0; i < near.size() && static_cast<int>(out.size()) + 1 < config_.window_keyframes; ++i)
    out.push_back(near[i].second);
  return out;
}

void VisualOdometry::refineInWindow(const FrameFeatures& cur, Estimate* est, StageTimes* times) const {
  const SE3 T_odom_cur = reference_->T_odom_cam * est->T_cur_kf.inverse();
  const auto window = selectWindow(T_odom_cur);
  if (window.empty()) return;
  auto t0 = Clock::now();
  std::vector<PointMatch> all = est->inlier_matches;
  const FeatureGrid grid(cur, camera_.width(), camera_.height());
  const SE3 T_ref_odom = reference_->T_odom_cam.inverse();
  for (const Keyframe* kf : window) {
    const SE3 T_cur_kf = T_odom_cur.inverse() * kf->T_odom_cam;
    const auto matches = matchByProjection(cur, grid, kf->features, T_cur_kf, camera_, config_.guided);
    // Express the keyframe's points in the reference keyframe so one refinement covers the window.
    const SE3 T_ref_kf = T_ref_odom * kf->T_odom_cam;
    for (auto& pm : toPointMatches(cur, kf->features, matches, config_.orb.scale_factor)) {
      pm.p_ref = T_ref_kf * pm.p_ref;
      all.push_back(pm);
    }
  }
  times->match_ms += msSince(t0);
  t0 = Clock::now();
  const RefineResult refined = refinePose(all, est->T_cur_kf, camera_, config_.refine);
  times->refine_ms += msSince(t0);
  // The window smooths; it does not make large corrections (those are the server's verified loop
  // closures). A result far from the reference-only estimate means an inconsistent window: keep the latter.
  const SE3 change = refined.T_cur_ref * est->T_cur_kf.inverse();
  if (refined.inliers >= est->inliers && se3::isValid(refined.T_cur_ref, 1e-4) &&
      change.translation().norm() <= config_.window_max_correction_m &&
      se3::rotationAngle(change) <= config_.window_max_correction_deg * M_PI / 180.0) {
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
  kf->id = first_keyframe_id_ + static_cast<int>(keyframes_.size());
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
  log::debug("odometry: frame ", r->frame_index, " lost against keyframe ", reference_->id, " and up to ",
             config_.relocalization_keyframes, " before it: ", r->matches, " matches, ", r->inliers,
             " inliers (", config_.min_tracking_inliers, " needed)");
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
  consecutive_lost_ = 0;
  r.segment = segment_;
  r.matches = est.matches;
  r.inliers = est.inliers;
  r.reference_keyframe = reference_->id;
  r.T_odom_cam = se3::normalized(reference_->T_odom_cam * est.T_cur_kf.inverse());
  ++frames_since_keyframe_;

  // N_k: the keyframe's features that can match, those with depth (keyframe_selector.hpp).
  const KeyframeDecision d =
      decideKeyframe(est.matches, r.features, static_cast<int>(reference_->features.countWithDepth()),
                     frames_since_keyframe_, est.T_cur_kf.inverse(), config_.keyframe);
  r.similarity = d.similarity;
  const bool make_keyframe =
      d.new_keyframe && static_cast<int>(cur.countWithDepth()) >= config_.min_keyframe_points;
  if ((make_keyframe || config_.window_every_frame) && config_.window_keyframes > 1) {
    // Only keyframe poses propagate drift, so the window's extra matching is spent on them alone.
    refineInWindow(cur, &est, &r.times);
    r.T_odom_cam = se3::normalized(reference_->T_odom_cam * est.T_cur_kf.inverse());
  }
  // After a relocalisation the difference to the last (extrapolated) pose is a correction, not motion.
  velocity_ =
      r.state == TrackingState::kRelocalized ? SE3::Identity() : T_odom_last_.inverse() * r.T_odom_cam;
  T_odom_last_ = r.T_odom_cam;
  if (make_keyframe) {
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
