#include "schur_bundle.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <Eigen/StdVector>

namespace rgbdmap::ba_detail {
namespace {

// Ceres' defaults for Levenberg-Marquardt (Solver::Options), so that both solvers stop alike.
constexpr double kInitialRadius = 1e4, kMaxRadius = 1e16, kMinRadius = 1e-32;
constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32;
constexpr double kMinRelativeDecrease = 1e-3, kFunctionTolerance = 1e-6, kParameterTolerance = 1e-8;
/// Reduced camera systems up to this many unknowns are factorised densely (a local window), larger ones
/// with a sparse Cholesky.
constexpr int kDenseMaxUnknowns = 600;

/// Huber as Ceres' HuberLoss(sqrt(b)) on the squared norm s: the cost rho(s) and its slope rho'(s).
struct Robust {
  double rho, weight;
};
Robust huber(double s, double b) {
  if (s <= b) return {s, 1.0};
  const double r = std::sqrt(b * s);
  return {2.0 * r - b, b / r};
}

/// A keyframe during the solve.
struct FrameState {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();
  Vec3 w = Vec3::Zero();
};

// Products of fixed-size blocks are written as lazyProduct: above 20 rows + columns + depth (a 9x3 by 3x9
// product) Eigen would take its general matrix-matrix path, several times slower at these sizes.
template <typename T>
using AlignedVector = std::vector<T, Eigen::aligned_allocator<T>>;

template <int N>
Eigen::Matrix<double, N, 1> dampingOf(const Eigen::Matrix<double, N, N>& H) {
  return H.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
}

}  // namespace

BaMeasurement measurementOf(const BaObservation& o, double sigma, const BaSolveConfig& c) {
  return {o.px, sigma, o.row_fraction, c.use_depth ? o.depth_m : 0.0, c.inverse_depth_sigma};
}

SolveSummary SchurBundle::solve(int iterations, const std::atomic<bool>* cancel) {
  // A frame has 9 unknowns only while some rolling-shutter rotation is estimated.
  bool any_w = false;
  if (w_free_ && c_.rolling_shutter)
    for (const BaFrame& f : p_.frames) any_w = any_w || !f.fixed_w;
  return any_w ? solveWith<9>(iterations, cancel) : solveWith<6>(iterations, cancel);
}

template <int D>
SolveSummary SchurBundle::solveWith(int iterations, const std::atomic<bool>* cancel) {
  using MatD = Eigen::Matrix<double, D, D>;
  using VecD = Eigen::Matrix<double, D, 1>;
  using MatD3 = Eigen::Matrix<double, D, 3>;
  const auto t0 = std::chrono::steady_clock::now();
  SolveSummary summary;
  const int nf = static_cast<int>(p_.frames.size()), np = static_cast<int>(p_.points.size());

  // The observations taking part, the frames and points they reach, and which of those are unknowns.
  std::vector<int> obs;
  std::vector<char> in_problem(nf, 0);
  std::vector<int> point_count(np, 0);
  for (size_t i = 0; i < p_.observations.size(); ++i) {
    if (!s_->active[i]) continue;
    obs.push_back(static_cast<int>(i));
    in_problem[p_.observations[i].frame] = 1;
    ++point_count[p_.observations[i].point];
  }
  std::vector<int> frame_var(nf, -1);
  std::vector<char> pose_free(nf, 0), w_var(nf, 0), has_prior(nf, 0);
  int nv = 0, free_poses = 0;
  for (int f = 0; f < nf; ++f) {
    if (!in_problem[f]) continue;
    const BaFrame& fr = p_.frames[f];
    has_prior[f] = c_.rolling_shutter && !fr.fixed_w;
    pose_free[f] = !fr.fixed;
    w_var[f] = D == 9 && w_free_ && has_prior[f];
    if (pose_free[f] || w_var[f]) frame_var[f] = nv++;
    free_poses += pose_free[f];
  }
  if (free_poses == 0) return summary;
  std::vector<int> var_frame(nv);
  for (int f = 0; f < nf; ++f)
    if (frame_var[f] >= 0) var_frame[frame_var[f]] = f;
  std::vector<int> point_var(np, -1), var_point;
  for (int j = 0; j < np; ++j)
    if (point_count[j] > 0) {
      point_var[j] = static_cast<int>(var_point.size());
      var_point.push_back(j);
    }
  const int npv = static_cast<int>(var_point.size());
  // Observations grouped by point (positions in `obs`).
  std::vector<int> point_start(npv + 1, 0), by_point(obs.size());
  for (int i : obs) ++point_start[point_var[p_.observations[i].point] + 1];
  for (int j = 0; j < npv; ++j) point_start[j + 1] += point_start[j];
  {
    std::vector<int> fill(point_start.begin(), point_start.end() - 1);
    for (size_t q = 0; q < obs.size(); ++q)
      by_point[fill[point_var[p_.observations[obs[q]].point]]++] = static_cast<int>(q);
  }

  // Per point, its observations by a frame unknown (positions in `obs`) and that unknown.
  std::vector<int> var_start(npv + 1, 0), var_obs, var_of;
  for (int j = 0; j < npv; ++j) {
    for (int x = point_start[j]; x < point_start[j + 1]; ++x) {
      const int a = frame_var[p_.observations[obs[by_point[x]]].frame];
      if (a < 0) continue;
      var_obs.push_back(by_point[x]);
      var_of.push_back(a);
    }
    var_start[j + 1] = static_cast<int>(var_obs.size());
  }

  const int n = nv * D;
  const bool dense = n <= kDenseMaxUnknowns;
  // A large reduced system (a global BA of a large map) is never formed: conjugate gradients apply it as
  // U - sum_j W_j V_j^-1 W_j^T, point by point (memory linear in the observations).
  const bool iterative = !dense && nv >= c_.iterative_min_frames;
  size_t max_track = 0;
  for (int j = 0; j < npv; ++j)
    max_track = std::max(max_track, static_cast<size_t>(var_start[j + 1] - var_start[j]));

  // The reduced camera system's blocks: (a, a) for every frame unknown, then (a, b), a > b, for frames
  // sharing a landmark; `pair_block` lists, per point in order, the block of each observation pair.
  std::vector<std::pair<int, int>> blocks;
  for (int a = 0; a < nv && !iterative; ++a) blocks.emplace_back(a, a);
  std::unordered_map<uint64_t, int> block_of;
  std::vector<int> pair_block;
  for (int j = 0; j < npv && !iterative; ++j) {
    for (int x = var_start[j]; x < var_start[j + 1]; ++x) {
      const int a = var_of[x];
      for (int y = var_start[j]; y < var_start[j + 1]; ++y) {
        const int b = var_of[y];
        if (a < b) continue;
        if (a == b) {
          pair_block.push_back(a);
          continue;
        }
        const uint64_t key = (static_cast<uint64_t>(a) << 32) | static_cast<uint32_t>(b);
        const auto [it, added] = block_of.try_emplace(key, static_cast<int>(blocks.size()));
        if (added) blocks.emplace_back(a, b);
        pair_block.push_back(it->second);
      }
    }
  }
  // Pose priors between frames in the problem; one whose two frames are both free adds a block (a, b).
  struct PriorTerm {
    const BaPosePrior* prior;
    int a, b;        ///< frame unknowns of its poses (-1: held)
    int block = -1;  ///< the (max, min) block when both are free
  };
  std::vector<PriorTerm> priors;
  for (const BaPosePrior& q : p_.priors) {
    if (!in_problem[q.frame_a] || !in_problem[q.frame_b]) continue;
    PriorTerm t{&q, pose_free[q.frame_a] ? frame_var[q.frame_a] : -1,
                pose_free[q.frame_b] ? frame_var[q.frame_b] : -1};
    if (t.a >= 0 && t.b >= 0 && !iterative) {
      const int hi = std::max(t.a, t.b), lo = std::min(t.a, t.b);
      const uint64_t key = (static_cast<uint64_t>(hi) << 32) | static_cast<uint32_t>(lo);
      const auto [it, added] = block_of.try_emplace(key, static_cast<int>(blocks.size()));
      if (added) blocks.emplace_back(hi, lo);
      t.block = it->second;
    }
    priors.push_back(t);
  }
  using Mat66 = Eigen::Matrix<double, 6, 6>;
  AlignedVector<Mat66> prior_cross(priors.size());  // J_hi^T J_lo per prior between two free frames

  Eigen::SparseMatrix<double> S_sparse;
  std::vector<int> column_offset;  // per block and column: index of its first stored value
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> sparse_llt;
  if (!dense && !iterative) {
    std::vector<Eigen::Triplet<double>> pattern;
    for (const auto& [a, b] : blocks)
      for (int c = 0; c < D; ++c)
        for (int r = a == b ? c : 0; r < D; ++r) pattern.emplace_back(a * D + r, b * D + c, 0.0);
    S_sparse.resize(n, n);
    S_sparse.setFromTriplets(pattern.begin(), pattern.end());
    S_sparse.makeCompressed();
    const int* outer = S_sparse.outerIndexPtr();
    const int* inner = S_sparse.innerIndexPtr();
    column_offset.resize(blocks.size() * D);
    for (size_t k = 0; k < blocks.size(); ++k) {
      const auto [a, b] = blocks[k];
      for (int c = 0; c < D; ++c) {
        const int col = b * D + c, row = a == b ? col : a * D;
        column_offset[k * D + c] =
            static_cast<int>(std::lower_bound(inner + outer[col], inner + outer[col + 1], row) - inner);
      }
    }
    sparse_llt.analyzePattern(S_sparse);
  }

  // The state, and the linearisation at it.
  std::vector<FrameState> frames(nf);
  for (int f = 0; f < nf; ++f) {
    const SE3 T = paramsToPose(s_->poses[f].data());
    frames[f] = {T.linear(), T.translation(), s_->w[f]};
  }
  std::vector<Vec3> points(s_->points);
  AlignedVector<MatD> U(nv);
  AlignedVector<VecD> g_frame(nv);
  std::vector<Mat3> V(npv);
  std::vector<Vec3> g_point(npv);
  AlignedVector<MatD3> W(obs.size());
  const double prior_info = 1.0 / (c_.rolling_shutter_sigma_rad * c_.rolling_shutter_sigma_rad);

  // The cost (0.5 * robust sum + priors); with `linearise`, also the normal equations' blocks (Huber by
  // its slope, as iteratively reweighted least squares). Infinity when a point falls behind a camera.
  const auto evaluate = [&](bool linearise) -> double {
    if (linearise) {
      for (int a = 0; a < nv; ++a) {
        U[a].setZero();
        g_frame[a].setZero();
      }
      for (int j = 0; j < npv; ++j) {
        V[j].setZero();
        g_point[j].setZero();
      }
    }
    double sum = 0.0;
    for (size_t q = 0; q < obs.size(); ++q) {
      const int i = obs[q];
      const BaObservation& o = p_.observations[i];
      const FrameState& F = frames[o.frame];
      const BaMeasurement m = measurementOf(o, s_->sigma_px[i], c_);
      Vec3 r = Vec3::Zero();
      Eigen::Matrix<double, 3, 6> J_pose = Eigen::Matrix<double, 3, 6>::Zero();
      Mat3 J_point = Mat3::Zero(), J_w = Mat3::Zero();
      const bool depth = m.depth_m > 0.0;
      if (depth) {
        ObservationJacobians<3> J;
        if (!observationJacobians<3>(p_.frames[o.frame].camera, m, F.R, F.t, points[o.point], F.w, r.data(),
                                     linearise ? &J : nullptr))
          return std::numeric_limits<double>::infinity();
        if (linearise) {
          J_pose = J.pose;
          J_point = J.point;
          J_w = J.w;
        }
      } else {
        ObservationJacobians<2> J;
        if (!observationJacobians<2>(p_.frames[o.frame].camera, m, F.R, F.t, points[o.point], F.w, r.data(),
                                     linearise ? &J : nullptr))
          return std::numeric_limits<double>::infinity();
        if (linearise) {
          J_pose.topRows<2>() = J.pose;
          J_point.topRows<2>() = J.point;
          J_w.topRows<2>() = J.w;
        }
      }
      const Robust h = huber(r.squaredNorm(), depth ? c_.chi2_3dof : c_.chi2_2dof);
      sum += h.rho;
      if (!linearise) continue;
      const double sw = std::sqrt(h.weight);
      r *= sw;
      J_point *= sw;
      const int j = point_var[o.point];
      V[j].noalias() += J_point.transpose() * J_point;
      g_point[j].noalias() += J_point.transpose() * r;
      const int a = frame_var[o.frame];
      if (a < 0) continue;
      Eigen::Matrix<double, 3, D> J_frame = Eigen::Matrix<double, 3, D>::Zero();
      if (pose_free[o.frame]) J_frame.template leftCols<6>() = sw * J_pose;
      if constexpr (D == 9)
        if (w_var[o.frame]) J_frame.template rightCols<3>() = sw * J_w;
      U[a].noalias() += J_frame.transpose().lazyProduct(J_frame);
      g_frame[a].noalias() += J_frame.transpose() * r;
      W[q].noalias() = J_frame.transpose() * J_point;
    }
    for (size_t k = 0; k < priors.size(); ++k) {
      const PriorTerm& t = priors[k];
      const auto poseOf = [&](int f) {
        SE3 T = SE3::Identity();
        T.linear() = frames[f].R;
        T.translation() = frames[f].t;
        return T;
      };
      const SE3 Ta = poseOf(t.prior->frame_a), Tb = poseOf(t.prior->frame_b);
      const Vec6 r = posePriorResidual(*t.prior, Ta, Tb);
      if (!r.allFinite()) return std::numeric_limits<double>::infinity();
      sum += r.squaredNorm();
      if (!linearise) continue;
      // Jacobians for the solver's left perturbation (T <- exp(d) T), by central differences.
      constexpr double kStep = 1e-6;
      Mat66 Ja = Mat66::Zero(), Jb = Mat66::Zero();
      for (int i = 0; i < 6; ++i) {
        const Vec6 d = Vec6::Unit(i) * kStep;
        if (t.a >= 0)
          Ja.col(i) = (posePriorResidual(*t.prior, se3::exp(d) * Ta, Tb) -
                       posePriorResidual(*t.prior, se3::exp(-d) * Ta, Tb)) /
                      (2.0 * kStep);
        if (t.b >= 0)
          Jb.col(i) = (posePriorResidual(*t.prior, Ta, se3::exp(d) * Tb) -
                       posePriorResidual(*t.prior, Ta, se3::exp(-d) * Tb)) /
                      (2.0 * kStep);
      }
      if (t.a >= 0) {
        U[t.a].template topLeftCorner<6, 6>().noalias() += Ja.transpose() * Ja;
        g_frame[t.a].template head<6>().noalias() += Ja.transpose() * r;
      }
      if (t.b >= 0) {
        U[t.b].template topLeftCorner<6, 6>().noalias() += Jb.transpose() * Jb;
        g_frame[t.b].template head<6>().noalias() += Jb.transpose() * r;
      }
      if (t.a >= 0 && t.b >= 0) prior_cross[k] = t.a > t.b ? Ja.transpose() * Jb : Jb.transpose() * Ja;
    }
    for (int f = 0; f < nf; ++f) {
      if (!in_problem[f] || !has_prior[f]) continue;
      sum += frames[f].w.squaredNorm() * prior_info;
      if (!linearise || !w_var[f]) continue;
      const int a = frame_var[f];
      U[a].template bottomRightCorner<3, 3>().diagonal().array() += prior_info;
      g_frame[a].template tail<3>() += prior_info * frames[f].w;
    }
    if (linearise)  // held parts of a frame unknown: a unit diagonal and no gradient keep their step 0
      for (int a = 0; a < nv; ++a) {
        const int f = var_frame[a];
        if (!pose_free[f]) U[a].template topLeftCorner<6, 6>().diagonal().setOnes();
        if (D == 9 && !w_var[f]) U[a].template bottomRightCorner<3, 3>().diagonal().setOnes();
      }
    return 0.5 * sum;
  };

  // The damped step (landmarks eliminated, reduced system solved, landmarks back-substituted) and the
  // decrease the linear model predicts for it; false when a system is not positive definite.
  AlignedVector<MatD> S_blocks(blocks.size());
  Eigen::VectorXd rhs(n), dx_frame(n);
  std::vector<Vec3> dx_point(npv);
  std::vector<Mat3> V_inv(npv);
  AlignedVector<MatD3> Y(max_track);
  Eigen::MatrixXd S_dense;
  AlignedVector<MatD> damped, P_inv;  // iterative: U + lambda D per frame; the block-Jacobi preconditioner
  Eigen::VectorXd cg_r, cg_z, cg_p, cg_q;
  // out = S v for the iterative solve (S: the reduced camera system at the damping in `damped`, V_inv).
  const auto applyS = [&](const Eigen::VectorXd& v, Eigen::VectorXd* out) {
    for (int a = 0; a < nv; ++a) out->segment<D>(a * D).noalias() = damped[a] * v.segment<D>(a * D);
    for (size_t k = 0; k < priors.size(); ++k) {
      const PriorTerm& t = priors[k];
      if (t.a < 0 || t.b < 0) continue;
      const int hi = std::max(t.a, t.b), lo = std::min(t.a, t.b);
      out->segment<6>(hi * D).noalias() += prior_cross[k] * v.segment<6>(lo * D);
      out->segment<6>(lo * D).noalias() += prior_cross[k].transpose() * v.segment<6>(hi * D);
    }
    for (int j = 0; j < npv; ++j) {
      Vec3 z = Vec3::Zero();
      for (int x = var_start[j]; x < var_start[j + 1]; ++x)
        z.noalias() += W[var_obs[x]].transpose() * v.segment<D>(var_of[x] * D);
      const Vec3 y = V_inv[j] * z;
      for (int x = var_start[j]; x < var_start[j + 1]; ++x)
        out->segment<D>(var_of[x] * D).noalias() -= W[var_obs[x]] * y;
    }
  };
  // Preconditioned conjugate gradients on S dx = rhs from dx = 0. Its iterates keep dx' (S dx - rhs) = 0,
  // so the predicted decrease below holds for a step it stops early (at its tolerance, step cap, the
  // solve's time limit or a cancel). False when S is found not positive definite.
  const auto solveIteratively = [&]() -> bool {
    dx_frame.setZero();
    cg_r = rhs;
    const auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd* z) {
      z->resize(n);
      for (int a = 0; a < nv; ++a) z->segment<D>(a * D).noalias() = P_inv[a] * r.segment<D>(a * D);
    };
    precondition(cg_r, &cg_z);
    cg_p = cg_z;
    cg_q.resize(n);
    double rz = cg_r.dot(cg_z);
    const double stop = c_.iterative_tolerance * rhs.norm();
    for (int k = 0; k < c_.iterative_max_steps && cg_r.norm() > stop; ++k) {
      if ((cancel && cancel->load()) ||
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > c_.max_time_s)
        break;
      applyS(cg_p, &cg_q);
      ++summary.linear_steps;
      const double pq = cg_p.dot(cg_q);
      if (!(pq > 0.0)) return false;
      const double alpha = rz / pq;
      dx_frame.noalias() += alpha * cg_p;
      cg_r.noalias() -= alpha * cg_q;
      precondition(cg_r, &cg_z);
      const double rz_next = cg_r.dot(cg_z);
      cg_p = cg_z + (rz_next / rz) * cg_p;
      rz = rz_next;
    }
    return true;
  };
  // Point j eliminated at damping lambda: V_inv[j], Y = W V^-1 for each of its observations by a frame
  // unknown, and its share of the reduced right-hand side. False when its damped block is singular.
  const auto eliminate = [&](int j, double lambda) -> bool {
    Mat3 Vd = V[j];
    Vd.diagonal() += lambda * dampingOf<3>(V[j]);
    bool invertible = false;
    Vd.computeInverseWithCheck(V_inv[j], invertible, 1e-300);
    if (!invertible) return false;
    const int first = var_start[j], count = var_start[j + 1] - first;
    for (int x = 0; x < count; ++x) {
      Y[x].noalias() = W[var_obs[first + x]] * V_inv[j];
      rhs.segment<D>(var_of[first + x] * D).noalias() += Y[x] * g_point[j];
    }
    return true;
  };
  const auto stepIteratively = [&](double lambda) -> bool {
    damped.resize(nv);
    P_inv.resize(nv);
    for (int a = 0; a < nv; ++a) {
      damped[a] = U[a];
      damped[a].diagonal() += lambda * dampingOf<D>(U[a]);
      P_inv[a] = damped[a];  // the diagonal block of S first, inverted below
      rhs.segment<D>(a * D) = -g_frame[a];
    }
    for (int j = 0; j < npv; ++j) {
      if (!eliminate(j, lambda)) return false;
      const int first = var_start[j], count = var_start[j + 1] - first;
      for (int x = 0; x < count; ++x)
        for (int y = 0; y < count; ++y)
          if (var_of[first + y] == var_of[first + x])
            P_inv[var_of[first + x]].noalias() -= Y[x].lazyProduct(W[var_obs[first + y]].transpose());
    }
    for (int a = 0; a < nv; ++a) {
      const Eigen::LLT<MatD> llt(P_inv[a]);
      if (llt.info() != Eigen::Success) return false;
      P_inv[a] = llt.solve(MatD::Identity());
    }
    return solveIteratively();
  };
  const auto stepDirectly = [&](double lambda) -> bool {
    for (int a = 0; a < nv; ++a) {
      S_blocks[a] = U[a];
      S_blocks[a].diagonal() += lambda * dampingOf<D>(U[a]);
      rhs.segment<D>(a * D) = -g_frame[a];
    }
    for (size_t k = nv; k < blocks.size(); ++k) S_blocks[k].setZero();
    for (size_t k = 0; k < priors.size(); ++k)
      if (priors[k].block >= 0) S_blocks[priors[k].block].template topLeftCorner<6, 6>() += prior_cross[k];
    size_t pair = 0;
    for (int j = 0; j < npv; ++j) {
      if (!eliminate(j, lambda)) return false;
      const int first = var_start[j], count = var_start[j + 1] - first;
      for (int x = 0; x < count; ++x) {
        const int a = var_of[first + x];
        for (int y = 0; y < count; ++y)
          if (var_of[first + y] <= a)
            S_blocks[pair_block[pair++]].noalias() -= Y[x].lazyProduct(W[var_obs[first + y]].transpose());
      }
    }
    if (dense) {
      S_dense.setZero(n, n);
      for (size_t k = 0; k < blocks.size(); ++k)
        S_dense.block<D, D>(blocks[k].first * D, blocks[k].second * D) = S_blocks[k];
      const Eigen::LLT<Eigen::MatrixXd, Eigen::Lower> llt(S_dense);
      if (llt.info() != Eigen::Success) return false;
      dx_frame = llt.solve(rhs);
    } else {
      double* values = S_sparse.valuePtr();
      for (size_t k = 0; k < blocks.size(); ++k) {
        const bool diagonal = blocks[k].first == blocks[k].second;
        for (int c = 0; c < D; ++c) {
          double* v = values + column_offset[k * D + c];
          for (int r = diagonal ? c : 0; r < D; ++r) *v++ = S_blocks[k](r, c);
        }
      }
      sparse_llt.factorize(S_sparse);
      if (sparse_llt.info() != Eigen::Success) return false;
      dx_frame = sparse_llt.solve(rhs);
    }
    return true;
  };
  const auto step = [&](double lambda, double* model_decrease) -> bool {
    if (iterative) {
      if (!stepIteratively(lambda)) return false;
    } else if (!stepDirectly(lambda)) {
      return false;
    }
    if (!dx_frame.allFinite()) return false;
    // Predicted decrease 0.5 * dx' (lambda D dx - g), over every unknown.
    double predicted = 0.0;
    for (int a = 0; a < nv; ++a) {
      const VecD d = dx_frame.segment<D>(a * D);
      predicted += d.dot(lambda * dampingOf<D>(U[a]).cwiseProduct(d) - g_frame[a]);
    }
    for (int j = 0; j < npv; ++j) {
      Vec3 b = -g_point[j];
      for (int x = var_start[j]; x < var_start[j + 1]; ++x)
        b.noalias() -= W[var_obs[x]].transpose() * dx_frame.segment<D>(var_of[x] * D);
      dx_point[j] = V_inv[j] * b;
      predicted += dx_point[j].dot(lambda * dampingOf<3>(V[j]).cwiseProduct(dx_point[j]) - g_point[j]);
    }
    *model_decrease = 0.5 * predicted;
    return true;
  };

  double cost = evaluate(true);
  summary.initial_cost = cost;
  double radius = kInitialRadius, decrease_factor = 2.0;
  std::vector<FrameState> frames_before;
  std::vector<Vec3> points_before;
  for (int it = 0; it < iterations && std::isfinite(cost); ++it) {
    if (cancel && cancel->load()) break;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > c_.max_time_s) {
      summary.out_of_time = true;
      break;
    }
    ++summary.iterations;
    double predicted = 0.0;
    if (!step(1.0 / radius, &predicted) || !(predicted > 0.0)) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius) break;
      continue;
    }
    // Converged in the parameters: the step is negligible against the state.
    double x_norm2 = 0.0, dx_norm2 = dx_frame.squaredNorm();
    for (int f = 0; f < nf; ++f) x_norm2 += frames[f].t.squaredNorm() + frames[f].w.squaredNorm() + 1.0;
    for (int j = 0; j < npv; ++j) {
      x_norm2 += points[var_point[j]].squaredNorm();
      dx_norm2 += dx_point[j].squaredNorm();
    }
    if (std::sqrt(dx_norm2) <= kParameterTolerance * (std::sqrt(x_norm2) + kParameterTolerance)) break;
    frames_before = frames;
    points_before = points;
    for (int a = 0; a < nv; ++a) {
      FrameState& F = frames[var_frame[a]];
      const VecD d = dx_frame.segment<D>(a * D);
      if (pose_free[var_frame[a]]) {
        const SE3 E = se3::exp(d.template head<6>());
        F.t = E.linear() * F.t + E.translation();
        F.R = E.linear() * F.R;
      }
      if constexpr (D == 9)
        if (w_var[var_frame[a]]) F.w += d.template tail<3>();
    }
    for (int j = 0; j < npv; ++j) points[var_point[j]] += dx_point[j];
    const double new_cost = evaluate(false);
    const double relative = (cost - new_cost) / predicted;
    if (std::isfinite(new_cost) && relative > kMinRelativeDecrease) {
      const bool converged = cost - new_cost <= kFunctionTolerance * cost;
      cost = new_cost;
      radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * relative - 1.0, 3)));
      decrease_factor = 2.0;
      if (converged) break;
      evaluate(true);
    } else {
      frames = std::move(frames_before);
      points = std::move(points_before);
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius) break;
    }
  }
  summary.final_cost = cost;
  for (int f = 0; f < nf; ++f) {
    if (frame_var[f] < 0) continue;
    SE3 T = SE3::Identity();
    T.linear() = frames[f].R;
    T.translation() = frames[f].t;
    poseToParams(T, s_->poses[f].data());
    s_->w[f] = frames[f].w;
  }
  for (int j = 0; j < npv; ++j) s_->points[var_point[j]] = points[var_point[j]];
  return summary;
}

template SolveSummary SchurBundle::solveWith<6>(int, const std::atomic<bool>*);
template SolveSummary SchurBundle::solveWith<9>(int, const std::atomic<bool>*);

}  // namespace rgbdmap::ba_detail
