#pragma once
// The own solver's cost and its linearisation: whitened reprojection (and inverse-depth) residuals under
// Huber's loss, the pose priors and the rolling-shutter prior, as Ceres evaluates them.
#include <vector>

#include "schur_structure.hpp"

namespace rgbdmap::ba_detail {

template <int D>
class SchurEvaluator {
 public:
  SchurEvaluator(const BaProblem& p, const BaSolveConfig& c, const std::vector<double>& sigma_px,
                 const SchurStructure& s);
  /// The cost (0.5 * robust sum + priors); with `lin`, also the normal equations' blocks (Huber by its
  /// slope, as iteratively reweighted least squares). Infinity when a point falls behind a camera.
  double evaluate(const std::vector<FrameState>& frames, const std::vector<Vec3>& points,
                  Linearisation<D>* lin) const;

 private:
  bool addObservations(const std::vector<FrameState>& frames, const std::vector<Vec3>& points,
                       Linearisation<D>* lin, double* sum) const;
  bool addPosePriors(const std::vector<FrameState>& frames, Linearisation<D>* lin, double* sum) const;
  void addRollingShutterPriors(const std::vector<FrameState>& frames, Linearisation<D>* lin,
                               double* sum) const;

  const BaProblem& p_;
  const BaSolveConfig& c_;
  const std::vector<double>& sigma_px_;
  const SchurStructure& s_;
  double prior_info_;
};

}  // namespace rgbdmap::ba_detail
