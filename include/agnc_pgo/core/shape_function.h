// The adaptive B-spline shape function of AGNC (Choi et al.): mu as a function
// of the GNC step, a clamped cubic B-spline whose control points interpolate
// between a gradual ("lower", inlier) and a rapid ("upper", outlier) set.
#pragma once

#include <array>

namespace agnc_pgo {
namespace core {

class ShapeFunction {
 public:
  // Number of GNC steps the curve spans: mu(k) = y(min(k / kStepsToOne, 1)).
  static constexpr int kStepsToOne = 3;

  // Builds the lower and upper curves (Eigen::Spline, degree 3, clamped knots
  // {0,0,0,0,.25,.5,.75,1,1,1,1}) and tabulates them at the step parameters.
  ShapeFunction();

  // The y-coordinate of the curve for interpolation parameter alpha in [0, 1]
  // (0 = lower/gradual, 1 = upper/rapid) at curve parameter t in [0, 1]. The
  // reference implementation ignores the x-coordinates. The curve is linear in
  // its control points, so this is lower(t) + alpha * (upper(t) - lower(t)).
  double muAtParameter(double alpha, double t) const;

  // mu at GNC step k >= 0 (t = min(k / 3, 1)), from the tabulated values.
  double muAtStep(double alpha, int step) const;

  // The process-wide instance (the curves are constants).
  static const ShapeFunction& instance();

 private:
  std::array<double, kStepsToOne + 1> lower_at_step_{};
  std::array<double, kStepsToOne + 1> upper_at_step_{};
};

}  // namespace core
}  // namespace agnc_pgo
