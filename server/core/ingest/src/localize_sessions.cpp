// Localising robots: placement state per session, the corrections they get.
#include "rgbdmap/ingest/localize_sessions.hpp"

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {

LocalizeSessions::Session& LocalizeSessions::session(const std::string& robot, int64_t session_id,
                                                     Clock::time_point received) {
  Session& s = sessions_[robot];
  if (s.session != session_id) {  // a new process of the robot: placed again from scratch
    s = Session{};
    s.session = session_id;
    s.first_received = received;
  }
  return s;
}

std::optional<PlacementEstimate> LocalizeSessions::predict(const std::string& robot, int64_t session,
                                                           const msg::Keyframe& kf) const {
  const auto it = sessions_.find(robot);
  if (it == sessions_.end() || it->second.session != session) return std::nullopt;
  return predicted(it->second, kf);
}

std::optional<PlacementEstimate> LocalizeSessions::predicted(const Session& s, const msg::Keyframe& kf) {
  // A segment that started after the placement (tracking was lost) has an odometry frame of its own.
  if (!s.placed || kf.segment_id != s.segment) return std::nullopt;
  return PlacementEstimate{s.map_id, se3::normalized(s.T_map_odom * kf.T_odom_cam), 0};
}

bool LocalizeSessions::seen(const std::string& robot, int64_t session, int keyframe_id) const {
  const auto it = sessions_.find(robot);
  return it != sessions_.end() && it->second.session == session && it->second.keyframes.count(keyframe_id);
}

bool LocalizeSessions::place(Session& s, const msg::Keyframe& kf, const std::vector<PlacementVote>& votes) {
  const std::optional<PlacementEstimate> prediction = predicted(s, kf);
  std::optional<PlacementEstimate> e = placeKeyframe(votes, prediction, config_);
  if (!e && !prediction) {
    // Two successive keyframes, one match each, that agree on the odometry frame also place the robot.
    const std::optional<PlacementEstimate> one = votes.size() == 1 ? bestVote(votes) : std::nullopt;
    std::optional<std::pair<int, SE3>> hypothesis;
    if (one)
      hypothesis = std::make_pair(one->map_id, se3::normalized(one->T_map_kf * kf.T_odom_cam.inverse()));
    if (hypothesis && s.single && s.single->first == hypothesis->first &&
        posesAgree(s.single->second, hypothesis->second, config_.agree_m, config_.agree_deg))
      e = PlacementEstimate{one->map_id, one->T_map_kf, 2};
    s.single = hypothesis;
  }
  if (!e) return false;
  s.placed = true;
  s.single.reset();
  s.map_id = e->map_id;
  s.segment = kf.segment_id;
  s.T_map_odom = se3::normalized(e->T_map_kf * kf.T_odom_cam.inverse());
  ++s.stats.keyframes_matched;
  return true;
}

LocalizeOutcome LocalizeSessions::take(const msg::Keyframe& kf, int64_t session_id, const SE3& mount,
                                       const std::vector<PlacementVote>& votes, Clock::time_point received,
                                       int64_t revision) {
  Session& s = session(kf.robot_id, session_id, received);
  s.keyframes[kf.keyframe_id] = {kf.segment_id, kf.T_odom_cam, std::nullopt};
  ++s.stats.keyframes;
  const bool was_placed = s.placed;
  place(s, kf, votes);
  LocalizeOutcome out;
  out.placed = s.placed;
  out.newly_placed = s.placed && !was_placed;
  if (s.placed)  // this keyframe, and at the first placement the segment's keyframes before it
    for (auto& [id, k] : s.keyframes)
      if (k.segment == s.segment && (id == kf.keyframe_id || !k.T_map_kf))
        k.T_map_kf = se3::normalized(s.T_map_odom * k.T_odom_kf);
  if (out.newly_placed) {
    s.stats.first_placement_s = std::chrono::duration<double>(Clock::now() - s.first_received).count();
    log::info("server: ", kf.robot_id, " placed in map ", s.map_id, " after ", s.stats.keyframes,
              " keyframe(s), ", s.stats.first_placement_s, " s after its first");
  }
  out.map_id = s.placed ? s.map_id : -1;
  out.T_map_kf =
      s.placed ? se3::normalized(s.T_map_odom * kf.T_odom_cam) : se3::normalized(mount * kf.T_odom_cam);
  s.stats.placed = s.placed;
  s.stats.map_id = out.map_id;
  out.corrections = corrections(s, kf.robot_id, mount, revision);
  return out;
}

msg::PoseCorrections LocalizeSessions::corrections(const Session& s, const std::string& robot,
                                                   const SE3& mount, int64_t revision) const {
  // Placed: the keyframes with a pose in the map (those of segments never placed are left out). Unplaced:
  // every keyframe in the provisional frame.
  msg::PoseCorrections c;
  c.robot_id = robot;
  c.graph_revision = revision;
  c.T_map_odom = s.placed ? s.T_map_odom : mount;
  for (auto it = s.keyframes.rbegin(); it != s.keyframes.rend(); ++it) {
    if (static_cast<int>(c.keyframes.size()) >= msg::kMaxCorrections) break;
    if (s.placed && !it->second.T_map_kf) continue;
    c.keyframes.push_back(
        {it->first, s.placed ? *it->second.T_map_kf : se3::normalized(mount * it->second.T_odom_kf)});
  }
  return c;
}

std::map<std::string, LocalizeRobotStats> LocalizeSessions::stats() const {
  std::map<std::string, LocalizeRobotStats> out;
  for (const auto& [robot, s] : sessions_) out[robot] = s.stats;
  return out;
}

}  // namespace rgbdmap
