// The Ceres side of the pose graph: residual helpers, connectivity and one robust LM solve.
#include <ceres/ceres.h>

#include <chrono>
#include <memory>
#include <numeric>
#include <unordered_set>

#include "graph_internal.hpp"
#include "rgbdmap/common/union_find.hpp"
#include "rgbdmap/graph/pose_graph_cost.hpp"
#include "rgbdmap/graph/pose_graph_residual.hpp"

namespace rgbdmap {

Mat6 residualInformation(const SE3& T_from_to, const Mat6& information_left) {
  // r = log(Z^-1 * T) with Z = exp(d) * Z_true gives r = -Ad(Z^-1) * d, so info_r = Ad(Z)^T * info * Ad(Z).
  Mat6 adjoint = Mat6::Zero();
  const Mat3 R = T_from_to.linear();
  adjoint.block<3, 3>(0, 0) = R;
  adjoint.block<3, 3>(0, 3) = se3::hat(T_from_to.translation()) * R;
  adjoint.block<3, 3>(3, 3) = R;
  const Mat6 info = adjoint.transpose() * information_left * adjoint;
  return 0.5 * (info + info.transpose());
}

bool sqrtInformation(const Mat6& information, Mat6* sqrt_information) {
  const Eigen::LLT<Mat6> llt(information);
  if (llt.info() != Eigen::Success || !information.allFinite()) return false;
  *sqrt_information = llt.matrixU();
  return sqrt_information->allFinite();
}

void packPose(const SE3& T_map_kf, double* pose7) {
  const Eigen::Quaterniond q = se3::quat(T_map_kf);
  pose7[0] = q.x();
  pose7[1] = q.y();
  pose7[2] = q.z();
  pose7[3] = q.w();
  Eigen::Map<Vec3>(pose7 + 4) = T_map_kf.translation();
}

SE3 unpackPose(const double* pose7) {
  const Eigen::Quaterniond q(pose7[3], pose7[0], pose7[1], pose7[2]);
  return se3::fromQuatTrans(q, Eigen::Map<const Vec3>(pose7 + 4));
}

namespace graph_detail {

std::vector<size_t> componentLabels(size_t num_nodes, const std::vector<EdgeEnds>& ends,
                                    const std::vector<bool>& mask) {
  UnionFind sets(num_nodes);
  for (size_t k = 0; k < ends.size(); ++k)
    if (mask[k]) sets.join(ends[k].from, ends[k].to);
  std::vector<size_t> labels(num_nodes);
  for (size_t i = 0; i < num_nodes; ++i) labels[i] = sets.find(i);
  return labels;
}

double edgeChi2(const PoseGraphEdge& edge, const Mat6& sqrt_info, const Pose7& from, const Pose7& to) {
  const RelativePoseResidual residual(edge.T_from_to, sqrt_info);
  Vec6 r;
  residual(from.data(), to.data(), r.data());
  return r.squaredNorm();
}

std::vector<bool> consistentEdges(const std::vector<PoseGraphEdge>& edges, const std::vector<Mat6>& sqrt_info,
                                  const std::vector<EdgeEnds>& ends, const std::vector<Pose7>& poses,
                                  const std::vector<bool>& enabled, double outlier_chi2) {
  std::vector<bool> next = enabled;
  for (size_t k = 0; k < edges.size(); ++k) {
    if (edges[k].kind == EdgeKind::kOdometry) continue;
    next[k] = edgeChi2(edges[k], sqrt_info[k], poses[ends[k].from], poses[ends[k].to]) <= outlier_chi2;
  }
  return next;
}

namespace {

class CancelCallback : public ceres::IterationCallback {
 public:
  explicit CancelCallback(const std::atomic<bool>* cancel) : cancel_(cancel) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_ && cancel_->load() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* cancel_;
};

ceres::Solver::Options solverOptions(const PoseGraphConfig& config) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  // Eigen's sparse Cholesky: as fast as SuiteSparse's CHOLMOD on sparse loops (52 vs 55 ms per solve of
  // bench_pose_graph), and single-threaded, whereas Debian's CHOLMOD starts OpenMP threads of its own. Dense
  // graphs go to conjugate gradients instead (solveOnce).
  options.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
  options.max_num_iterations = config.max_iterations;
  if (config.max_solver_time_s > 0.0) options.max_solver_time_in_seconds = config.max_solver_time_s;
  options.function_tolerance = config.function_tolerance;
  options.num_threads = std::max(1, config.num_threads);
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  return options;
}

ceres::CostFunction* makeCost(const PoseGraphEdge& edge, const Mat6& sqrt_info, bool analytic) {
  if (analytic) return new RelativePoseCost(edge.T_from_to, sqrt_info);
  return new ceres::AutoDiffCostFunction<RelativePoseResidual, 6, 7, 7>(
      new RelativePoseResidual(edge.T_from_to, sqrt_info));
}

/// Stops a solve after the first iteration whose conjugate gradients needed the cap (poses kept).
class CgCapCallback : public ceres::IterationCallback {
 public:
  explicit CgCapCallback(int cap) : cap_(cap) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& it) override {
    if (it.linear_solver_iterations < cap_) return ceres::SOLVER_CONTINUE;
    hit_ = true;
    return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }
  bool hit() const { return hit_; }

 private:
  int cap_;
  bool hit_ = false;
};

/// The residual blocks of a spanning forest of the solved graph, odometry first: every odometry edge (a
/// chain per robot session, so already a forest) and then each loop edge that joins two trees. Its normal
/// equations are a tree's, which sparse Cholesky factors without fill-in; Levenberg-Marquardt's diagonal
/// (which Ceres adds to the subset) makes them definite although no node of the tree is held fixed.
std::unordered_set<ceres::ResidualBlockId> spanningTree(const std::vector<PoseGraphEdge>& edges,
                                                        const std::vector<EdgeEnds>& ends,
                                                        const std::vector<ceres::ResidualBlockId>& block_ids,
                                                        size_t num_nodes) {
  UnionFind sets(num_nodes);
  std::unordered_set<ceres::ResidualBlockId> tree;
  for (const bool odometry : {true, false})
    for (size_t k = 0; k < edges.size(); ++k)
      if (block_ids[k] && (edges[k].kind == EdgeKind::kOdometry) == odometry &&
          sets.join(ends[k].from, ends[k].to))
        tree.insert(block_ids[k]);
  return tree;
}

/// The robust loss of loop edges (odometry edges have none).
std::unique_ptr<ceres::LossFunction> makeLoopLoss(const PoseGraphConfig& config) {
  std::unique_ptr<ceres::LossFunction> loop_loss;
  if (config.use_cauchy) {
    loop_loss = std::make_unique<ceres::CauchyLoss>(config.loop_loss_scale);
  } else {
    loop_loss = std::make_unique<ceres::HuberLoss>(config.loop_loss_scale);
  }
  return loop_loss;
}

/// One residual block per enabled edge; the ids of the blocks per edge (nullptr for a disabled edge).
std::vector<ceres::ResidualBlockId> addEdges(ceres::Problem* problem, const std::vector<PoseGraphEdge>& edges,
                                             const std::vector<Mat6>& sqrt_info,
                                             const std::vector<EdgeEnds>& ends,
                                             const std::vector<bool>& enabled, ceres::LossFunction* loop_loss,
                                             bool analytic, std::vector<Pose7>* poses) {
  std::vector<ceres::ResidualBlockId> block_ids(edges.size(), nullptr);
  for (size_t k = 0; k < edges.size(); ++k) {
    if (!enabled[k]) continue;
    ceres::LossFunction* loss = edges[k].kind == EdgeKind::kOdometry ? nullptr : loop_loss;
    block_ids[k] = problem->AddResidualBlock(makeCost(edges[k], sqrt_info[k], analytic), loss,
                                             (*poses)[ends[k].from].data(), (*poses)[ends[k].to].data());
  }
  return block_ids;
}

/// Puts the poses the edges use on the SE(3) manifold and holds the fixed ones constant; returns how many
/// are left free.
int setPoseBlocks(ceres::Problem* problem, ceres::Manifold* manifold, const std::vector<bool>& fixed,
                  std::vector<Pose7>* poses) {
  int free_blocks = 0;
  for (size_t i = 0; i < poses->size(); ++i) {
    double* block = (*poses)[i].data();
    if (!problem->HasParameterBlock(block)) continue;
    problem->SetManifold(block, manifold);
    if (fixed[i])
      problem->SetParameterBlockConstant(block);
    else
      ++free_blocks;
  }
  return free_blocks;
}

/// Whether the graph is dense enough for conjugate gradients. A room revisited many times ties every
/// keyframe to ~10 others anywhere in the graph: its normal equations fill in almost completely under
/// Cholesky (BM_PoseGraphFleetRoom/3000, 27,000 loops: ~2.8 s and GBs per iteration), while such a
/// well-connected graph is well conditioned for conjugate gradients (~0.15 s per iteration, linear in the
/// edges). Long sparse chains are the opposite (a circle with 200 loops: 89 ms with Cholesky, 723 ms with
/// CG), hence the switch on density.
bool solveIteratively(const PoseGraphConfig& config, int free_blocks, int residual_blocks) {
  return config.iterative_min_edges_per_node > 0.0 && free_blocks >= config.iterative_min_nodes &&
         residual_blocks >= config.iterative_min_edges_per_node * free_blocks;
}

/// Switches a conjugate-gradients solve to the spanning-tree preconditioner (and off the CG cap callback).
void useTreePreconditioner(ceres::Solver::Options* options, const std::vector<PoseGraphEdge>& edges,
                           const std::vector<EdgeEnds>& ends,
                           const std::vector<ceres::ResidualBlockId>& block_ids, size_t num_nodes,
                           CancelCallback* cancel_callback) {
  options->preconditioner_type = ceres::SUBSET;
  options->residual_blocks_for_subset_preconditioner = spanningTree(edges, ends, block_ids, num_nodes);
  options->callbacks = {cancel_callback};
}

/// The outcome of a finished solve (its iteration counts already in `outcome`), or why it failed.
Result<SolveOutcome> finishOutcome(const ceres::Solver::Summary& summary, int steps,
                                   const PoseGraphConfig& config, SolveOutcome outcome) {
  if (summary.termination_type == ceres::FAILURE) {
    return Result<SolveOutcome>::failure("pose graph solve failed: " + summary.message);
  }
  outcome.final_cost = summary.final_cost;
  outcome.cancelled = summary.termination_type == ceres::USER_FAILURE;
  // NO_CONVERGENCE is the iteration limit (deterministic) or the time limit (depends on the machine's load).
  outcome.out_of_time = summary.termination_type == ceres::NO_CONVERGENCE && steps < config.max_iterations;
  outcome.converged = summary.termination_type == ceres::CONVERGENCE;
  return outcome;
}

}  // namespace

Result<SolveOutcome> solveOnce(const std::vector<PoseGraphEdge>& edges, const std::vector<Mat6>& sqrt_info,
                               const std::vector<EdgeEnds>& ends, const std::vector<bool>& enabled,
                               const std::vector<bool>& fixed, const PoseGraphConfig& config,
                               const std::atomic<bool>* cancel, std::vector<Pose7>* poses, bool tree_first) {
  const std::unique_ptr<ceres::LossFunction> loop_loss = makeLoopLoss(config);
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> manifold;
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  const std::vector<ceres::ResidualBlockId> block_ids =
      addEdges(&problem, edges, sqrt_info, ends, enabled, loop_loss.get(), config.analytic_jacobians, poses);
  const int free_blocks = setPoseBlocks(&problem, &manifold, fixed, poses);
  SolveOutcome outcome;
  if (problem.NumResidualBlocks() == 0) return outcome;

  ceres::Solver::Options options = solverOptions(config);
  const bool iterative = solveIteratively(config, free_blocks, problem.NumResidualBlocks());
  if (iterative) {
    options.linear_solver_type = ceres::CGNR;
    options.preconditioner_type = ceres::JACOBI;
    options.max_linear_solver_iterations = config.iterative_max_cg_iterations;
  }
  CancelCallback cancel_callback(cancel);
  options.callbacks.push_back(&cancel_callback);
  // Block Jacobi suits a compact, densely looped graph (the room: 2-116 CG steps per iteration) but not
  // long chains, whose drift it spreads one node per CG step (rooms joined by long stretches: the cap of
  // 200 steps in most iterations, and a solve that stops far from the optimum while its step and cost
  // change look converged). The first iteration that needs the cap switches the rest of the solve to the
  // spanning tree, which carries a chain's drift exactly in one application.
  CgCapCallback cap_callback(config.iterative_max_cg_iterations);
  if (iterative && config.iterative_tree_fallback) {
    if (tree_first) {
      outcome.tree_preconditioner = true;
      useTreePreconditioner(&options, edges, ends, block_ids, poses->size(), &cancel_callback);
    } else {
      options.callbacks.push_back(&cap_callback);
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  outcome.iterations = static_cast<int>(summary.iterations.size());
  outcome.initial_cost = summary.initial_cost;
  int steps = summary.num_successful_steps + summary.num_unsuccessful_steps;
  if (cap_callback.hit() && summary.termination_type == ceres::USER_SUCCESS) {
    outcome.tree_preconditioner = true;
    useTreePreconditioner(&options, edges, ends, block_ids, poses->size(), &cancel_callback);
    options.max_num_iterations = std::max(1, config.max_iterations - steps);
    const double spent = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (config.max_solver_time_s > 0.0)
      options.max_solver_time_in_seconds = std::max(1e-3, config.max_solver_time_s - spent);
    ceres::Solve(options, &problem, &summary);
    outcome.iterations += static_cast<int>(summary.iterations.size());
    steps += summary.num_successful_steps + summary.num_unsuccessful_steps;
  }
  return finishOutcome(summary, steps, config, outcome);
}

}  // namespace graph_detail
}  // namespace rgbdmap
