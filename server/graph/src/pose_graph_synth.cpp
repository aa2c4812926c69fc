#include "rgbdmap/graph/pose_graph_synth.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace rgbdmap {
namespace {

SE3 circlePose(const SynthGraphConfig& c, int k) {
  const double angle = 2.0 * M_PI * k / c.keyframes_per_lap;
  SE3 T = SE3::Identity();
  T.translation() =
      Vec3(c.radius_m * std::cos(angle), c.radius_m * std::sin(angle), 0.3 * std::sin(3 * angle));
  const Mat3 yaw = se3::expSO3(Vec3(0, 0, angle + M_PI / 2));
  const Mat3 pitch = se3::expSO3(Vec3(0, 0.1 * std::sin(2 * angle), 0));
  T.linear() = yaw * pitch;
  return c.T_map_start * T;
}

SE3 perturb(const SE3& T, double sigma_t, double sigma_r, std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec6 d;
  for (int i = 0; i < 3; ++i) d[i] = sigma_t * n(*rng);
  for (int i = 3; i < 6; ++i) d[i] = sigma_r * n(*rng);
  return se3::normalized(se3::exp(d) * T);  // left perturbation, as the information assumes
}

void addEdge(SynthGraph* s, int64_t from, int64_t to, const SE3& T_from_to, const Mat6& info, EdgeKind kind) {
  PoseGraphEdge e;
  e.id = s->next_edge_id++;
  e.from = from;
  e.to = to;
  e.T_from_to = T_from_to;
  e.information = info;
  e.kind = kind;
  s->graph.addEdge(e);
}

}  // namespace

Mat6 diagonalInformation(double sigma_t, double sigma_r) {
  Vec6 d;
  d << Vec3::Constant(1.0 / (sigma_t * sigma_t)), Vec3::Constant(1.0 / (sigma_r * sigma_r));
  return d.asDiagonal();
}

void appendSynthRobot(const SynthGraphConfig& c, SynthGraph* s) {
  std::mt19937 rng(c.seed);
  const size_t base = s->T_map_kf_true.size();
  const Mat6 odom_info = diagonalInformation(c.odom_sigma_t, c.odom_sigma_r);
  const Mat6 loop_info = diagonalInformation(c.loop_sigma_t, c.loop_sigma_r);
  if (s->next_edge_id < c.first_edge_id) s->next_edge_id = c.first_edge_id;
  SE3 T_map_chain = circlePose(c, 0);
  for (int k = 0; k < c.keyframes; ++k) {
    const SE3 T_true = circlePose(c, k);
    const int64_t id = c.first_node_id + k;
    s->T_map_kf_true.push_back(T_true);
    s->node_ids.push_back(id);
    if (k == 0) {
      s->graph.addNode(id, c.robot, T_true);
      continue;
    }
    const SE3 T_prev_cur = perturb(circlePose(c, k - 1).inverse() * T_true, c.noise_scale * c.odom_sigma_t,
                                   c.noise_scale * c.odom_sigma_r, &rng);
    T_map_chain = T_map_chain * T_prev_cur;
    s->graph.addNode(id, c.robot, c.initial_from_odometry ? T_map_chain : T_true);
    addEdge(s, id - 1, id, T_prev_cur, odom_info, EdgeKind::kOdometry);
  }
  for (int k = c.keyframes_per_lap; k < c.keyframes; k += c.loop_every) {
    const int j = k % c.keyframes_per_lap + c.keyframes_per_lap * ((k / c.keyframes_per_lap) - 1);
    const SE3 T_true = s->T_map_kf_true[base + j].inverse() * s->T_map_kf_true[base + k];
    s->loop_edge_ids.push_back(s->next_edge_id);
    addEdge(s, c.first_node_id + j, c.first_node_id + k,
            perturb(T_true, c.noise_scale * c.loop_sigma_t, c.noise_scale * c.loop_sigma_r, &rng), loop_info,
            EdgeKind::kLoop);
  }
  // Further loops to the same place in random earlier laps (drawn after the above: the default graphs are
  // unchanged).
  for (int k = 2 * c.keyframes_per_lap; c.loop_laps > 1 && k < c.keyframes; k += c.loop_every) {
    const int lap = k / c.keyframes_per_lap;
    std::vector<int> earlier;  // laps before the previous one
    for (int l = 0; l + 1 < lap; ++l) earlier.push_back(l);
    std::shuffle(earlier.begin(), earlier.end(), rng);
    earlier.resize(std::min<size_t>(earlier.size(), static_cast<size_t>(c.loop_laps - 1)));
    for (int l : earlier) {
      const int j = k % c.keyframes_per_lap + c.keyframes_per_lap * l;
      const SE3 T_true = s->T_map_kf_true[base + j].inverse() * s->T_map_kf_true[base + k];
      s->loop_edge_ids.push_back(s->next_edge_id);
      addEdge(s, c.first_node_id + j, c.first_node_id + k,
              perturb(T_true, c.noise_scale * c.loop_sigma_t, c.noise_scale * c.loop_sigma_r, &rng),
              loop_info, EdgeKind::kLoop);
    }
  }
  std::uniform_int_distribution<int> pick(0, c.keyframes - 1);
  for (int f = 0; f < c.false_loops;) {
    const int a = pick(rng), b = pick(rng);
    if ((s->T_map_kf_true[base + a].translation() - s->T_map_kf_true[base + b].translation()).norm() < 2.0)
      continue;
    s->false_edge_ids.push_back(s->next_edge_id);
    s->loop_edge_ids.push_back(s->next_edge_id);
    addEdge(s, c.first_node_id + a, c.first_node_id + b, perturb(SE3::Identity(), 0.2, 0.1, &rng), loop_info,
            EdgeKind::kLoop);
    ++f;
  }
}

SynthGraphConfig revisitedRoom(int keyframes, int loop_laps, uint32_t seed) {
  SynthGraphConfig c;
  c.keyframes = keyframes;
  c.keyframes_per_lap = 46;
  c.radius_m = 1.5;
  c.loop_every = 1;
  c.loop_laps = loop_laps;
  c.seed = seed;
  return c;
}

SynthGraph makeSynthGraph(const SynthGraphConfig& config) {
  SynthGraph s;
  appendSynthRobot(config, &s);
  return s;
}

double translationRmse(const PoseGraph& graph, const SynthGraph& synth, int robot) {
  double sum = 0.0;
  int count = 0;
  for (const auto& node : graph.nodes()) {
    if (robot >= 0 && node.robot != robot) continue;
    for (size_t k = 0; k < synth.node_ids.size(); ++k) {
      if (synth.node_ids[k] != node.id) continue;
      sum += (node.T_map_kf.translation() - synth.T_map_kf_true[k].translation()).squaredNorm();
      ++count;
    }
  }
  return count == 0 ? 0.0 : std::sqrt(sum / count);
}

}  // namespace rgbdmap
