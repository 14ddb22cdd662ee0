#include "agnc_pgo/core/shape_function.h"

#include <algorithm>

#include <unsupported/Eigen/Splines>

namespace agnc_pgo {
namespace core {
namespace {

using Curve = Eigen::Spline<double, 2, 3>;

// Clamped cubic knot vector with three interior knots (7 control points).
Curve::KnotVectorType knots() {
  Curve::KnotVectorType k(11);
  k << 0, 0, 0, 0, 0.25, 0.5, 0.75, 1, 1, 1, 1;
  return k;
}

// Gradual rise, used for likely inliers (alpha = 0).
Curve lowerCurve() {
  Curve::ControlPointVectorType points(2, 7);
  points << 0, 0.02, 0.1, 0.2, 0.4, 0.7, 1,  //
      0, 0.3, 0.6, 0.8, 0.9, 0.98, 1;
  return Curve(knots(), points);
}

// Rapid rise, used for likely outliers (alpha = 1).
Curve upperCurve() {
  Curve::ControlPointVectorType points(2, 7);
  points << 0, 0, 0, 0, 0.2, 0.5, 1,  //
      0, 0.5, 0.8, 1, 1, 1, 1;
  return Curve(knots(), points);
}

double clamp01(double v) { return std::min(1.0, std::max(0.0, v)); }

}  // namespace

ShapeFunction::ShapeFunction() {
  const Curve lower = lowerCurve();
  const Curve upper = upperCurve();
  for (int k = 0; k <= kStepsToOne; ++k) {
    const double t = static_cast<double>(k) / kStepsToOne;
    lower_at_step_[k] = clamp01(lower(t)(1));
    upper_at_step_[k] = clamp01(upper(t)(1));
  }
  // The clamped curve interpolates its end points exactly; pin them so that
  // "mu == 1" comparisons downstream are exact.
  lower_at_step_[kStepsToOne] = upper_at_step_[kStepsToOne] = 1.0;
  lower_at_step_[0] = upper_at_step_[0] = 0.0;
}

double ShapeFunction::muAtParameter(double alpha, double t) const {
  static const Curve lower = lowerCurve();
  static const Curve upper = upperCurve();
  const double u = clamp01(t);
  const double a = clamp01(alpha);
  return clamp01(lower(u)(1) + a * (upper(u)(1) - lower(u)(1)));
}

double ShapeFunction::muAtStep(double alpha, int step) const {
  const int k = std::min(std::max(step, 0), kStepsToOne);
  const double a = clamp01(alpha);
  return lower_at_step_[k] + a * (upper_at_step_[k] - lower_at_step_[k]);
}

const ShapeFunction& ShapeFunction::instance() {
  static const ShapeFunction shape;
  return shape;
}

}  // namespace core
}  // namespace agnc_pgo
