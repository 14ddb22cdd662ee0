// The scale-invariant graduated (SIG) robust kernel of riSAM as a Ceres loss.
//
//   rho(r; mu) = 1/2 * c^2 r^2 / (c^2 + r^(2 mu)),   0 <= mu <= 1
//
// mu = 0 is a scaled quadratic (weight c^2/(c^2+1)), mu = 1 is Geman-McClure.
// Ceres hands a loss the squared whitened residual s = r^2 and multiplies by
// 1/2 itself, so on s:
//   rho[0] = c^2 s / (c^2 + s^mu)
//   rho[1] = w = c^2 (c^2 + (1 - mu) s^mu) / (c^2 + s^mu)^2   (the IRLS weight)
//   rho[2] = 0   -- deliberately: Ceres then scales residual and Jacobian by
//                   sqrt(w), the iteratively-reweighted least squares step that
//                   the reference (GTSAM) implementation takes.
// mu is mutable so the GNC engine can graduate each loop closure between
// solves without rebuilding the problem.
#pragma once

#include <ceres/loss_function.h>

namespace agnc_pgo {
namespace core {

class SigLoss : public ceres::LossFunction {
 public:
  explicit SigLoss(double mu = 0.0, double shape_c = 3.0) : mu_(mu), c2_(shape_c * shape_c) {}

  void Evaluate(double s, double rho[3]) const override;

  void setMu(double mu) { mu_ = mu; }
  double mu() const { return mu_; }

  // rho(r; mu) on the (non-squared) whitened residual norm r.
  double rho(double r) const;
  // The IRLS weight w(r; mu) = rho'(r) / r.
  double weight(double r) const;

 private:
  double mu_;
  double c2_;
};

}  // namespace core
}  // namespace agnc_pgo
