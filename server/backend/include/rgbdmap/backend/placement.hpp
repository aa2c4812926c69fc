#pragma once
// Placement of a robot that localises in a stored map (a robot in map mode "localize"): which verified
// matches of its keyframe against the map's keyframes are believed, and the pose they give. A pure
// function of the matches and the robot's prediction: the ingest side keeps the state (LocalizeSessions).
//
// A wrong placement is the failure that matters (the robot would avoid obstacles of another place), so a
// first placement needs independent evidence that agrees: at least `first_min_agreeing` verified matches
// to distinct map keyframes of one map that put the keyframe within agree_m / agree_deg of each other, or
// (the caller's part) two successive keyframes whose single matches agree on the robot's T_map_odom. Once
// placed, a match is believed only within track_gate_m / track_gate_deg of the pose odometry predicts.
#include <optional>
#include <vector>

#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

struct PlacementConfig {
  int first_min_agreeing = 2;  ///< verified matches to distinct map keyframes for a first placement
  double agree_m = 0.05;       ///< matches agree when their poses are this close ...
  double agree_deg = 3.0;      ///< ... in position and in rotation
  double track_gate_m = 0.25;  ///< once placed: matches this far from the prediction are not believed
  double track_gate_deg = 10.0;
};

/// One verified match of the robot's keyframe with a map keyframe: the keyframe's pose it implies.
struct PlacementVote {
  int map_keyframe = -1;  ///< the stored keyframe (node id)
  int map_id = -1;        ///< the map that keyframe is in
  SE3 T_map_kf = SE3::Identity();
  int inliers = 0;  ///< the weight of the vote
};

struct PlacementEstimate {
  int map_id = -1;
  SE3 T_map_kf = SE3::Identity();  ///< the inlier-weighted mean of the agreeing votes
  int agreeing = 0;                ///< votes (distinct map keyframes) behind it
};

/// True when the two poses are within `metres` and `degrees` of each other.
bool posesAgree(const SE3& a, const SE3& b, double metres, double degrees);

/// Inlier-weighted mean of poses (positions averaged, rotations by the chordal mean).
SE3 weightedMeanPose(const std::vector<SE3>& poses, const std::vector<double>& weights);

/// Without a prediction (the robot is unplaced): the largest group of votes of one map that agree with its
/// best vote, if it holds first_min_agreeing distinct map keyframes; with one (map id, T_map_kf predicted by
/// odometry from the last placement): the votes in that map within the track gate, if any.
std::optional<PlacementEstimate> placeKeyframe(const std::vector<PlacementVote>& votes,
                                               const std::optional<PlacementEstimate>& predicted,
                                               const PlacementConfig& config);

/// The single best vote of one keyframe (most inliers), for the two-keyframe rule of a first placement.
std::optional<PlacementEstimate> bestVote(const std::vector<PlacementVote>& votes);

}  // namespace rgbdmap
