#pragma once
// Internals of PoseGraph shared by its source files: connectivity, the Ceres solve, submap alignment.
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap::graph_detail {

using Pose7 = std::array<double, 7>;

/// Component label (smallest member index) per node over the edges where mask is true.
std::vector<size_t> componentLabels(size_t num_nodes, const std::vector<EdgeEnds>& ends,
                                    const std::vector<bool>& mask);

struct SolveOutcome {
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  bool cancelled = false;
  bool out_of_time = false;  ///< stopped by max_solver_time_s before converging (a load-dependent answer)
  bool converged = false;    ///< Ceres' convergence test ended it (not a limit, not a cancel)
  bool tree_preconditioner = false;  ///< CG used the spanning tree (from the start or after Jacobi's cap)
};

/// One Levenberg-Marquardt solve over the enabled edges; nodes with fixed[i] are held constant. With
/// conjugate gradients, `tree_first` starts with the spanning-tree preconditioner instead of block Jacobi.
Result<SolveOutcome> solveOnce(const std::vector<PoseGraphEdge>& edges, const std::vector<Mat6>& sqrt_info,
                               const std::vector<EdgeEnds>& ends, const std::vector<bool>& enabled,
                               const std::vector<bool>& fixed, const PoseGraphConfig& config,
                               const std::atomic<bool>* cancel, std::vector<Pose7>* poses,
                               bool tree_first = false);

/// Whitened chi2 (no robust loss) of one edge at the given poses.
double edgeChi2(const PoseGraphEdge& edge, const Mat6& sqrt_info, const Pose7& from, const Pose7& to);

/// Consistency check: the enabled mask after testing every loop and inter-robot edge (disabled ones
/// included, so that they can come back) against the chi2 threshold; odometry edges keep their flag.
std::vector<bool> consistentEdges(const std::vector<PoseGraphEdge>& edges, const std::vector<Mat6>& sqrt_info,
                                  const std::vector<EdgeEnds>& ends, const std::vector<Pose7>& poses,
                                  const std::vector<bool>& enabled, double outlier_chi2);

/// Moves submaps (joined by enabled non-inter-robot edges) that contain no fixed node rigidly onto the
/// anchored ones they connect to by enabled inter-robot edges, using the correction most edges agree on.
/// Returns the number of submaps moved; `moved_by` (optional) gets, per node, the label of the submap whose
/// correction moved it, or -1.
int alignSubmaps(const std::vector<PoseGraphEdge>& edges, const std::vector<EdgeEnds>& ends,
                 const std::vector<bool>& enabled, const std::vector<bool>& fixed,
                 const PoseGraphConfig& config, std::vector<SE3>* T_map_kf,
                 std::vector<long>* moved_by = nullptr);

}  // namespace rgbdmap::graph_detail
