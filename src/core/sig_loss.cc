#include "agnc_pgo/core/sig_loss.h"

#include <cmath>

namespace agnc_pgo {
namespace core {

void SigLoss::Evaluate(double s, double rho[3]) const {
  // s^mu with s = 0 is 0 for mu > 0 and 1 for mu = 0; std::pow handles both.
  const double s_mu = std::pow(s, mu_);
  const double denominator = c2_ + s_mu;
  rho[0] = c2_ * s / denominator;
  rho[1] = c2_ * (c2_ + (1.0 - mu_) * s_mu) / (denominator * denominator);
  rho[2] = 0.0;  // IRLS: see the header.
}

double SigLoss::rho(double r) const {
  double values[3];
  Evaluate(r * r, values);
  return 0.5 * values[0];
}

double SigLoss::weight(double r) const {
  double values[3];
  Evaluate(r * r, values);
  return values[1];
}

}  // namespace core
}  // namespace agnc_pgo
