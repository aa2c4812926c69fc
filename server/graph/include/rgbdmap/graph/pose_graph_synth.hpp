#pragma once
// Deterministic synthetic pose graphs with exact ground truth, for tests and benchmarks: a robot driving
// `laps` circles (with a gentle height and pitch wave), noisy odometry chained into the initial poses, loop
// edges between keyframes at the same place on different laps, and optional false loops.
#include <cstdint>
#include <vector>

#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap {

struct SynthGraphConfig {
  int robot = 0;
  int64_t first_node_id = 0;
  int64_t first_edge_id = 0;
  int keyframes = 200;
  int keyframes_per_lap = 100;
  double radius_m = 5.0;
  SE3 T_map_start = SE3::Identity();                 ///< ground-truth pose of the circle's frame in the map
  double odom_sigma_t = 0.01, odom_sigma_r = 0.004;  ///< per edge, metres and radians (1 sigma per axis)
  double loop_sigma_t = 0.01, loop_sigma_r = 0.004;
  double noise_scale = 1.0;  ///< scales the noise drawn (0: exact edges); the information keeps the sigmas
  int loop_every = 5;        ///< a loop edge from every n-th keyframe after the first lap to the same place
  int false_loops = 0;       ///< extra wrong loops between far-apart keyframes claiming they coincide
  /// Loop edges of a loop keyframe: to the same place in this many earlier laps (the previous one first, the
  /// rest drawn at random), e.g. 10 for a fleet revisiting one room (every keyframe meets many passes).
  int loop_laps = 1;
  bool initial_from_odometry = true;  ///< chain noisy odometry (else: start at ground truth)
  uint32_t seed = 1;
};

struct SynthGraph {
  PoseGraph graph;
  std::vector<SE3> T_map_kf_true;  ///< ground truth, parallel to node_ids
  std::vector<int64_t> node_ids;
  std::vector<int64_t> loop_edge_ids;
  std::vector<int64_t> false_edge_ids;
  int64_t next_edge_id = 0;
};

/// Builds the graph; fixes no node (the caller decides the gauge).
SynthGraph makeSynthGraph(const SynthGraphConfig& config);

/// A room revisited pass after pass, as by the 16-robot fleet run: `keyframes` on laps of 46 keyframes
/// (radius 1.5 m), every keyframe after the first lap with loops to the same place in `loop_laps` earlier
/// laps (the previous one and random others).
SynthGraphConfig revisitedRoom(int keyframes, int loop_laps, uint32_t seed);

/// Appends the robot of `config` to an existing graph (ids must not collide).
void appendSynthRobot(const SynthGraphConfig& config, SynthGraph* synth);

/// Information matrix diag(1/sigma_t^2 x3, 1/sigma_r^2 x3).
Mat6 diagonalInformation(double sigma_t, double sigma_r);

/// Translation RMSE of the graph's poses against the ground truth of `synth` (no alignment: the gauge is
/// what it is). `robot` < 0: all robots.
double translationRmse(const PoseGraph& graph, const SynthGraph& synth, int robot = -1);

}  // namespace rgbdmap
