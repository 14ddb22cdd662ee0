#include "agnc_pgo/core/chi_square.h"

#include <boost/math/distributions/chi_squared.hpp>

namespace agnc_pgo {
namespace core {

double chiSquareQuantile(int dof, double probability) {
  return boost::math::quantile(boost::math::chi_squared(dof), probability);
}

double chiSquareCdf(int dof, double value) {
  if (value <= 0.0) return 0.0;
  return boost::math::cdf(boost::math::chi_squared(dof), value);
}

ChiSquareThresholds ChiSquareThresholds::forDof(int dof) {
  ChiSquareThresholds t;
  t.q25 = chiSquareQuantile(dof, 0.25);
  t.q90 = chiSquareQuantile(dof, 0.90);
  t.q95 = chiSquareQuantile(dof, 0.95);
  return t;
}

}  // namespace core
}  // namespace agnc_pgo
