#include "reduced_camera_system.hpp"

#include <algorithm>
#include <cstdint>
#include <unordered_map>

namespace rgbdmap::ba_detail {

BlockPattern buildBlockPattern(SchurStructure* s) {
  BlockPattern bp;
  for (int a = 0; a < s->nv; ++a) bp.blocks.emplace_back(a, a);
  std::unordered_map<uint64_t, int> block_of;
  const auto blockOf = [&](int hi, int lo) {
    const uint64_t key = (static_cast<uint64_t>(hi) << 32) | static_cast<uint32_t>(lo);
    const auto [it, added] = block_of.try_emplace(key, static_cast<int>(bp.blocks.size()));
    if (added) bp.blocks.emplace_back(hi, lo);
    return it->second;
  };
  for (int j = 0; j < s->npv; ++j) {
    for (int x = s->var_start[j]; x < s->var_start[j + 1]; ++x) {
      const int a = s->var_of[x];
      for (int y = s->var_start[j]; y < s->var_start[j + 1]; ++y) {
        const int b = s->var_of[y];
        if (a < b) continue;
        bp.pair_block.push_back(a == b ? a : blockOf(a, b));
      }
    }
  }
  for (PriorTerm& t : s->priors)
    if (t.a >= 0 && t.b >= 0) t.block = blockOf(std::max(t.a, t.b), std::min(t.a, t.b));
  return bp;
}

template <int D>
ReducedCameraSystem<D>::ReducedCameraSystem(SchurStructure* s, bool dense)
    : s_(*s), pattern_(buildBlockPattern(s)), S_blocks_(pattern_.blocks.size()), rhs_(s->nv * D) {
  if (!dense) sparse_ = std::make_unique<SparseCholesky<D>>(pattern_.blocks, s->nv * D);
}

template <int D>
bool ReducedCameraSystem<D>::assemble(const Linearisation<D>& lin, double lambda, PointElimination<D>* points) {
  for (int a = 0; a < s_.nv; ++a) {
    S_blocks_[a] = lin.U[a];
    S_blocks_[a].diagonal() += lambda * dampingOf<D>(lin.U[a]);
    rhs_.segment<D>(a * D) = -lin.g_frame[a];
  }
  for (size_t k = s_.nv; k < pattern_.blocks.size(); ++k) S_blocks_[k].setZero();
  for (size_t k = 0; k < s_.priors.size(); ++k)
    if (s_.priors[k].block >= 0)
      S_blocks_[s_.priors[k].block].template topLeftCorner<6, 6>() += lin.prior_cross[k];
  size_t pair = 0;
  for (int j = 0; j < s_.npv; ++j) {
    if (!points->eliminate(s_, lin, j, lambda, &rhs_)) return false;
    const int first = s_.var_start[j], count = s_.var_start[j + 1] - first;
    for (int x = 0; x < count; ++x) {
      const int a = s_.var_of[first + x];
      for (int y = 0; y < count; ++y)
        if (s_.var_of[first + y] <= a)
          S_blocks_[pattern_.pair_block[pair++]].noalias() -=
              points->Y[x].lazyProduct(lin.W[s_.var_obs[first + y]].transpose());
    }
  }
  return true;
}

template <int D>
bool ReducedCameraSystem<D>::solve(const Linearisation<D>& lin, double lambda, PointElimination<D>* points,
                                   Eigen::VectorXd* dx_frame) {
  if (!assemble(lin, lambda, points)) return false;
  if (sparse_) return sparse_->solve(pattern_.blocks, S_blocks_, rhs_, dx_frame);
  return dense_.solve(pattern_.blocks, S_blocks_, rhs_, dx_frame);
}

template class ReducedCameraSystem<6>;
template class ReducedCameraSystem<9>;

}  // namespace rgbdmap::ba_detail
