// Chi-square quantiles (Boost.Math) used by every GNC decision.
#pragma once

namespace agnc_pgo {
namespace core {

// Inverse CDF of the chi-square distribution with `dof` degrees of freedom.
double chiSquareQuantile(int dof, double probability);
double chiSquareCdf(int dof, double value);

// The three thresholds every decision uses, precomputed once per dimension.
struct ChiSquareThresholds {
  double q25 = 0;  // below: confident inlier
  double q90 = 0;  // at or above: confident outlier
  double q95 = 0;  // final classification threshold
  static ChiSquareThresholds forDof(int dof);
};

}  // namespace core
}  // namespace agnc_pgo
