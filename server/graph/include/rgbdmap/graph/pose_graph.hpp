#pragma once
// Multi-robot keyframe pose graph on SE(3), optimised with Ceres. Plain structs in, plain structs out:
// no transport, no files. Nodes are keyframes (T_map_kf), edges relative poses with an information matrix.
#include <atomic>
#include <cstdint>
#include <map>
#include <optional>
#include <unordered_map>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

struct PoseGraphConfig {
  /// Robust loss on loop and inter-robot edges, scale in sigmas of the whitened residual norm.
  double loop_loss_scale = 3.0;
  /// Cauchy (true) or Huber (false) on loop edges. Odometry edges always use the plain squared loss.
  bool use_cauchy = true;
  /// Levenberg-Marquardt iterations per solve (one solve per outlier round).
  int max_iterations = 50;
  /// Wall-clock limit per solve; 0 = none (max_iterations bounds the work, and the answer does not depend
  /// on the machine's load).
  double max_solver_time_s = 0.0;
  /// Relative cost change at which a solve stops.
  double function_tolerance = 1e-6;
  /// Whitened chi2 (6 dof) above which a loop edge is disabled after a solve; 22.46 = 99.9% quantile.
  double outlier_chi2 = 22.46;
  /// Re-solves after disabling (or re-admitting) loop edges; 0 turns the consistency check off.
  int max_outlier_rounds = 3;
  /// The server's optimiser solves the whole graph after new loop edges only when one of them has a
  /// whitened chi2 above this at the current poses (the estimate does not explain it yet: drift to correct,
  /// or a false loop to reject) or maps merged or chains joined. A loop the estimate already satisfies is
  /// kept without a solve, as a converged solve would keep it (bundle adjustment uses its matches). 0:
  /// solve after every loop. 12.59 = the 6-dof 95% quantile.
  double solve_above_chi2 = 12.59;
  /// Linear solver per solve: sparse Cholesky, or conjugate gradients (CGNR, Jacobi preconditioner) when at
  /// least iterative_min_nodes nodes are free and there are at least iterative_min_edges_per_node edges per
  /// free node: a room revisited by many passes fills the Cholesky factor in almost completely (seconds and
  /// GBs per iteration) but is well conditioned for CG. 0 edges per node: always Cholesky.
  double iterative_min_edges_per_node = 4.0;
  int iterative_min_nodes = 200;
  int iterative_max_cg_iterations = 200;  ///< per Levenberg-Marquardt iteration
  /// CG's preconditioner is block Jacobi; the first Levenberg-Marquardt iteration whose CG needs all
  /// iterative_max_cg_iterations steps (long chains, for which Jacobi is poor) switches the rest of the
  /// solve, and every later CG solve of the same graph, to the exact inverse of a spanning tree (every
  /// odometry edge plus the loops joining chains: a tree factors without fill-in; Ceres' SUBSET
  /// preconditioner). false: block Jacobi throughout.
  bool iterative_tree_fallback = true;
  /// Ceres threads; the service runs the optimiser on one core.
  int num_threads = 1;
  /// Analytic Jacobians (RelativePoseCost); false: Ceres autodiff of RelativePoseResidual (same residual).
  bool analytic_jacobians = true;
  /// A submap (nodes joined by odometry and same-robot loops) newly connected to an anchored one by
  /// inter-robot edges is moved rigidly onto it first if that moves it by more than these.
  double merge_align_translation_m = 0.3;
  double merge_align_rotation_rad = 0.05;
  /// Two inter-robot edges agree on the alignment when their implied corrections differ by less than these.
  double merge_consensus_translation_m = 0.5;
  double merge_consensus_rotation_rad = 0.1;
  /// The server's optimiser solves new loops' neighbourhood first: up to this many nodes nearest (in edges)
  /// to them, the nodes around it held fixed (PoseGraph::optimizeLocal). It keeps that answer when every
  /// edge there then fits (chi2 <= outlier_chi2); otherwise (a loop closing a long cycle, a false loop) it
  /// solves the whole graph, which alone may disable loops. 0: always the whole graph.
  int local_max_nodes = 300;
  /// A neighbourhood solve is refused when an edge that fitted before it (chi2 <= outlier_chi2) ends above
  /// this: the region strained against the fixed nodes around it (a loop closing a long cycle gives chi2 in
  /// the thousands). Above outlier_chi2, because edges near the threshold may cross it as the region
  /// settles against surroundings that were themselves only solved locally; the whole-graph solve when
  /// quiet judges them. 44.9: the 6-dof chi2 exceeded with probability 5e-8.
  double local_strain_chi2 = 44.9;
};

enum class EdgeKind { kOdometry, kLoop, kInterRobot };
const char* toString(EdgeKind kind);

struct PoseGraphNode {
  int64_t id = 0;  ///< keyframe global id
  int robot = 0;
  SE3 T_map_kf = SE3::Identity();
  bool fixed = false;
};

struct PoseGraphEdge {
  int64_t id = 0;
  int64_t from = 0, to = 0;
  SE3 T_from_to = SE3::Identity();
  /// Information of T_from_to for a left perturbation, tangent order (rho, omega), as Keyframe::information.
  Mat6 information = Mat6::Identity();
  EdgeKind kind = EdgeKind::kOdometry;
};

struct OptimizeReport {
  int iterations = 0;  ///< LM iterations summed over all solves
  int solves = 0;
  double initial_cost = 0.0;  ///< Ceres cost (0.5 * robust sum) before the first solve
  double final_cost = 0.0;    ///< after the last solve
  double time_ms = 0.0;
  int loops_total = 0;  ///< loop + inter-robot edges
  int loops_rejected = 0;
  std::vector<int64_t> rejected_edge_ids;
  int merged_submaps = 0;  ///< submaps moved onto an anchored one before solving
  bool cancelled = false;
  /// A solve ran out of max_solver_time_s: its poses are kept (they lower the cost), but it judges no loop
  /// edge (the disabled set stays as the last converged solve left it).
  bool out_of_time = false;
  /// A solve stopped at max_iterations: likewise kept, and it judges no loop edge.
  bool iteration_limit = false;
  /// Solves whose conjugate gradients switched from block Jacobi to the spanning tree
  /// (iterative_tree_fallback).
  int tree_preconditioned_solves = 0;
};

/// What PoseGraph::optimizeLocal() did.
struct LocalOptimizeReport {
  /// The region's poses were written: the solve converged, every seed edge that touches the region then
  /// has a chi2 <= outlier_chi2 and every edge of the solve (to the fixed nodes around the region included)
  /// that had one before has a chi2 <= local_strain_chi2. Otherwise the graph is unchanged. (Seed edges
  /// beyond local_max_nodes are not in the solve and not judged: the whole-graph solve owed when quiet
  /// covers them.)
  bool accepted = false;
  /// The region grew to its whole component: nothing was solved (a whole-graph solve is the same work and
  /// may also judge loops).
  bool whole_component = false;
  int region_nodes = 0;    ///< nodes free in the solve
  int boundary_nodes = 0;  ///< nodes around the region, held fixed
  int edges = 0;           ///< enabled edges in the solve
  int iterations = 0;
  double worst_chi2 = 0.0;         ///< after the solve, the largest chi2 of the seed edges
  double worst_strain_chi2 = 0.0;  ///< after the solve, the largest chi2 of the other edges that fitted
  bool out_of_time = false;
  bool cancelled = false;
  double time_ms = 0.0;
  std::vector<int64_t> moved_nodes;  ///< the region's node ids when accepted
};

namespace graph_detail {
/// Node indices (not ids) of an edge's two ends.
struct EdgeEnds {
  size_t from = 0, to = 0;
};
}  // namespace graph_detail

class PoseGraph {
 public:
  /// Adds a keyframe; fails on a duplicate id or an invalid pose.
  Status addNode(int64_t id, int robot, const SE3& T_map_kf);
  /// Adds an edge; fails on a duplicate id, unknown nodes, a self-edge, an invalid pose or an information
  /// matrix that is not symmetric positive definite.
  Status addEdge(const PoseGraphEdge& edge);
  /// Holds a node in place during optimisation (the first keyframe of the first robot, anchors).
  Status setFixed(int64_t id, bool fixed = true);
  Status setPose(int64_t id, const SE3& T_map_kf);
  /// Replaces an edge's measurement (its information stays), e.g. by the relative pose bundle adjustment
  /// refined; fails on an unknown edge or an invalid pose.
  Status setEdgeMeasurement(int64_t id, const SE3& T_from_to);
  /// The edge with this id, or null.
  const PoseGraphEdge* edge(int64_t id) const;
  /// Whitened chi2 (no robust loss) of an edge at the current poses; nullopt for an unknown id.
  std::optional<double> edgeChi2(int64_t id) const;

  /// What alignSubmaps() did: the nodes it moved and the enabled edges whose residual the moves changed
  /// (their two ends moved by different corrections, or only one of them moved).
  struct Alignment {
    std::vector<int64_t> moved_nodes;
    std::vector<int64_t> changed_edges;
  };
  /// Moves submaps joined to the anchored map by inter-robot edges only (a robot's map or a new chain met
  /// for the first time) rigidly onto it, by the correction most of those edges agree on: what optimize()
  /// does before it solves. Lets a caller see whether a merge alone already explains the new edges.
  Alignment alignSubmaps(const PoseGraphConfig& config);

  /// Optimises all nodes. Loop edges whose whitened chi2 stays above outlier_chi2 are disabled (and
  /// re-admitted once they fit again). Each connected component without a fixed node has its first node
  /// held during the solve. `cancel` (optional) aborts the running solve when set; poses are then kept.
  Result<OptimizeReport> optimize(const PoseGraphConfig& config, const std::atomic<bool>* cancel = nullptr);

  /// Optimises the neighbourhood of the enabled edges `edge_ids` (e.g. new loop edges): a breadth-first
  /// region over enabled edges from their ends, of up to config.local_max_nodes nodes, the nodes adjacent to
  /// it held fixed, the enabled set kept (no loop is disabled or re-admitted here). Writes the region's poses
  /// only when the answer is accepted (see LocalOptimizeReport). Cost: the region's edges, plus one pass
  /// over the graph's edges to find it.
  LocalOptimizeReport optimizeLocal(const std::vector<int64_t>& edge_ids, const PoseGraphConfig& config,
                                    const std::atomic<bool>* cancel = nullptr);

  /// Takes an optimised solution of an earlier snapshot of this graph (from PoseGraphOptimizer): nodes in
  /// `T_map_kf` get those poses; nodes added since follow the correction of the latest earlier node of their
  /// robot; `disabled_edge_ids` becomes the disabled set (unknown ids are ignored). Returns the number of
  /// nodes that were moved by a correction.
  int applyOptimized(const std::map<int64_t, SE3>& T_map_kf, const std::vector<int64_t>& disabled_edge_ids);

  std::optional<SE3> pose(int64_t id) const;
  std::map<int64_t, SE3> poses() const;
  /// What the measurements alone say about the nodes near `source`: T_source_node, the product of the
  /// measurements along a path of fewest hops over enabled edges, for every node within `max_hops` hops
  /// (the source itself included, as the identity), up to `max_nodes` nodes. No pose estimate enters, so it
  /// holds while an optimisation is pending (a loop just added, chains not yet joined by a solve). Empty for
  /// an unknown source. Cost: the nodes reached and their edges.
  std::unordered_map<int64_t, SE3> measuredPosesNear(int64_t source, int max_hops, size_t max_nodes) const;
  /// Loop edges disabled by the last optimize(), ascending ids.
  const std::vector<int64_t>& disabledEdges() const { return disabled_edges_; }
  /// Node ids grouped by connectivity over enabled edges, each group in insertion order; groups ordered by
  /// their first node. Two robots' nodes in one group means their maps are merged.
  std::vector<std::vector<int64_t>> components() const;

  const std::vector<PoseGraphNode>& nodes() const { return nodes_; }
  const std::vector<PoseGraphEdge>& edges() const { return edges_; }

 private:
  std::vector<bool> enabledMask() const;
  /// Fixed flags used by the solve: the caller's plus each unfixed component's first node.
  std::vector<bool> gaugeFixed(const std::vector<bool>& enabled) const;

  std::vector<PoseGraphNode> nodes_;
  std::vector<PoseGraphEdge> edges_;
  std::vector<Mat6> sqrt_information_;  ///< per edge, in the residual's frame
  std::unordered_map<int64_t, size_t> node_index_;
  std::unordered_map<int64_t, size_t> edge_index_;
  /// An edge at a node: its index, the node at its other end (index), whether it leaves this node (from).
  struct Incidence {
    uint32_t edge, other;
    bool forward;
  };
  std::vector<std::vector<Incidence>> incident_;  ///< per node (index), in insertion order
  std::vector<graph_detail::EdgeEnds> ends_;      ///< per edge (index)
  std::vector<int64_t> disabled_edges_;
  /// A solve of this graph found block Jacobi too weak for its conjugate gradients (the cap reached): later
  /// CG solves start with the spanning tree (iterative_tree_fallback). Chains do not go away as a map grows.
  bool cg_tree_ = false;
};

}  // namespace rgbdmap
