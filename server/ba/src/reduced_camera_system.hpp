#pragma once
// The reduced camera system formed block-sparse: S = U + lambda D_U - sum_j W_j V_j^-1 W_j^T over the
// blocks (a, a) of every frame unknown and (a, b), a > b, of frames sharing a landmark or a pose prior,
// then factorised densely (a small window) or with a sparse Cholesky.
#include <memory>
#include <utility>
#include <vector>

#include "dense_cholesky.hpp"
#include "schur_step.hpp"
#include "sparse_cholesky.hpp"

namespace rgbdmap::ba_detail {

/// The blocks of the reduced camera system: (a, a) for every frame unknown, then (a, b), a > b, for
/// frames sharing a landmark, then for pose priors between two free frames (whose PriorTerm::block it
/// sets); `pair_block` lists, per point in order, the block of each of its observation pairs.
struct BlockPattern {
  std::vector<std::pair<int, int>> blocks;
  std::vector<int> pair_block;
};
BlockPattern buildBlockPattern(SchurStructure* s);

template <int D>
class ReducedCameraSystem final : public SchurStep<D> {
 public:
  using MatD = Eigen::Matrix<double, D, D>;
  /// Sets the priors' blocks in `s`; `dense`: factorised densely, else the sparse pattern is analysed.
  ReducedCameraSystem(SchurStructure* s, bool dense);
  bool solve(const Linearisation<D>& lin, double lambda, PointElimination<D>* points,
             Eigen::VectorXd* dx_frame) override;

 private:
  /// The damped frame blocks and the prior blocks, then each point's elimination subtracted.
  bool assemble(const Linearisation<D>& lin, double lambda, PointElimination<D>* points);

  const SchurStructure& s_;
  BlockPattern pattern_;
  AlignedVector<MatD> S_blocks_;
  Eigen::VectorXd rhs_;
  DenseCholesky<D> dense_;
  std::unique_ptr<SparseCholesky<D>> sparse_;  ///< null: dense
};

}  // namespace rgbdmap::ba_detail
