#include "rgbdmap/graph/pose_graph_config_table.hpp"

namespace rgbdmap {

const ConfigTable<PoseGraphConfig>& poseGraphConfigTable() {
  using C = PoseGraphConfig;
  using R = ConfigRange;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("loop_loss_scale", &C::loop_loss_scale, R::closed(0.01, 1000.0),
               "robust loss scale on loop edges, in sigmas")
          .add("use_cauchy", &C::use_cauchy, "Cauchy (true) or Huber (false)")
          .add("max_iterations", &C::max_iterations, R::closed(1, 10000),
               "Levenberg-Marquardt iterations per solve")
          .add("max_solver_time_s", &C::max_solver_time_s, R::closed(0.0, 3600.0),
               "wall-clock limit per solve, 0 = none (max_iterations bounds it)")
          .add("outlier_chi2", &C::outlier_chi2, R::closed(0.1, 1e6),
               "loop edges above this whitened chi2 (6 dof, 99.9%) are disabled after a solve")
          .add("max_outlier_rounds", &C::max_outlier_rounds, R::closed(0, 100),
               "re-solves after disabling or re-admitting loop edges; 0 turns the check off")
          .add("solve_above_chi2", &C::solve_above_chi2, R::closed(0.0, 1e6),
               "the server solves the whole graph after loops only when one has a whitened chi2 above this "
               "at the current poses (or maps merged); 0: after every loop")
          .add("local_max_nodes", &C::local_max_nodes, R::closed(0, 1000000),
               "the server solves new loops' neighbourhood of this many nodes first (nodes around it fixed) "
               "and keeps the answer when every edge there fits; else the whole graph. 0: always the whole "
               "graph")
          .add("local_strain_chi2", &C::local_strain_chi2, R::closed(0.1, 1e6),
               "a neighbourhood solve is refused when an edge that fitted ends above this chi2 (strained "
               "against the fixed nodes around it)")
          .add(
              "iterative_min_edges_per_node", &C::iterative_min_edges_per_node, R::closed(0.0, 1e6),
              "a solve uses conjugate gradients instead of sparse Cholesky with at least this many edges per "
              "free node (dense loops, e.g. a fleet in one room); 0: always Cholesky")
          .add("iterative_min_nodes", &C::iterative_min_nodes, R::closed(1, 100000000),
               "... and at least this many free nodes")
          .add("iterative_max_cg_iterations", &C::iterative_max_cg_iterations, R::closed(1, 100000),
               "conjugate-gradient steps per Levenberg-Marquardt iteration")
          .add("iterative_tree_fallback", &C::iterative_tree_fallback,
               "CG (block Jacobi) switches to a spanning-tree preconditioner (odometry and the loops joining "
               "chains, solved exactly) once an iteration needs iterative_max_cg_iterations steps")
          .add("num_threads", &C::num_threads, R::closed(1, 256), "Ceres threads");
  return table;
}

}  // namespace rgbdmap
