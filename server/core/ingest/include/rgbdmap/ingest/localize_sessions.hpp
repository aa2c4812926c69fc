#pragma once
// Robots that localise in the stored map (map mode "localize": their Hello asks, or server.frozen_map):
// per robot session, whether it is placed, the map it is placed in and its T_map_odom, and what it is sent
// back. Its keyframes are never stored: each one is matched against the map (MapGraph::placeVotes), judged
// by the back-end's placement rules (rgbdmap/backend/placement.hpp) and answered with PoseCorrections of
// every keyframe of the session. Until it is placed the robot's keyframes are in a provisional frame of its
// own (T_map_kf = its camera mount * T_odom_kf, as an unmerged mapping robot's are), so that a robot that
// waits for a correction after each keyframe is answered at once. Used under the ingest state lock.
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/backend/placement.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

/// What became of one localising keyframe.
struct LocalizeOutcome {
  msg::PoseCorrections corrections;  ///< every keyframe of the session, to the robot
  bool placed = false;               ///< the session is placed (now or before)
  bool newly_placed = false;         ///< by this keyframe
  int map_id = -1;                   ///< the map it is placed in (-1: its own provisional frame)
  SE3 T_map_kf = SE3::Identity();    ///< this keyframe's pose in that map (or in its own frame)
};

/// A localising robot's row in the stats.
struct LocalizeRobotStats {
  bool placed = false;
  int map_id = -1;
  double first_placement_s = -1.0;  ///< from its session's first keyframe to its first placement; -1: not yet
  uint64_t keyframes = 0;           ///< localising keyframes taken (never stored)
  uint64_t keyframes_matched = 0;   ///< of them, placed by matches of their own (not by odometry alone)
};

class LocalizeSessions {
 public:
  using Clock = std::chrono::steady_clock;
  explicit LocalizeSessions(const PlacementConfig& config) : config_(config) {}

  /// The pose odometry predicts for `kf` in the map its session is placed in; nullopt while unplaced.
  std::optional<PlacementEstimate> predict(const std::string& robot, int64_t session,
                                           const msg::Keyframe& kf) const;
  /// The keyframe with its matches (votes); `mount`: the robot's camera mount (its provisional frame);
  /// `received`: when its first copy came (for the time to first placement); `revision`: the corrections'
  /// graph_revision (increasing per robot).
  LocalizeOutcome take(const msg::Keyframe& kf, int64_t session, const SE3& mount,
                       const std::vector<PlacementVote>& votes, Clock::time_point received, int64_t revision);
  /// True when this robot session already took keyframe `keyframe_id` (a resend: answered again only).
  bool seen(const std::string& robot, int64_t session, int keyframe_id) const;
  std::map<std::string, LocalizeRobotStats> stats() const;

 private:
  struct Keyframe {
    int segment = 0;
    SE3 T_odom_kf = SE3::Identity();
    std::optional<SE3> T_map_kf;  ///< once placed: by its own matches, else by T_map_odom at that time
  };
  struct Session {
    int64_t session = 0;
    std::map<int, Keyframe> keyframes;  ///< by keyframe id
    bool placed = false;
    int map_id = -1;
    SE3 T_map_odom = SE3::Identity();  ///< of the segment placed last (its odometry frame)
    int segment = 0;
    /// The single-vote hypothesis of the previous keyframe (two-keyframe rule): map id and T_map_odom.
    std::optional<std::pair<int, SE3>> single;
    Clock::time_point first_received;
    LocalizeRobotStats stats;
  };
  Session& session(const std::string& robot, int64_t session_id, Clock::time_point received);
  /// T_map_kf odometry predicts for `kf` in the session's map; nullopt while unplaced or on a new segment.
  static std::optional<PlacementEstimate> predicted(const Session& s, const msg::Keyframe& kf);
  bool place(Session& s, const msg::Keyframe& kf, const std::vector<PlacementVote>& votes);
  msg::PoseCorrections corrections(const Session& s, const std::string& robot, const SE3& mount,
                                   int64_t revision) const;

  PlacementConfig config_;
  std::map<std::string, Session> sessions_;
};

}  // namespace rgbdmap
