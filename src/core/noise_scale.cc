#include "agnc_pgo/core/noise_scale.h"

#include <algorithm>
#include <cmath>

#include "agnc_pgo/core/chi_square.h"

namespace agnc_pgo {
namespace core {

NoiseScale::NoiseScale(int dof) : dof_(dof) {}

void NoiseScale::add(double d2, int pairs) {
  if (std::isfinite(d2) && pairs >= 1) samples_.push_back({d2, pairs});
}

int NoiseScale::belowQuartile(double k) const {
  // Under scale k, the least of m chi^2 draws (times k) has
  // u = 1 - (1 - F(d2 / k))^m uniform on (0, 1).
  int count = 0;
  for (const Sample& s : samples_)
    if (1.0 - std::pow(1.0 - chiSquareCdf(dof_, s.d2 / k), s.pairs) < 0.25) ++count;
  return count;
}

double NoiseScale::estimate() const {
  // The number of samples below their quartile is Binomial(n, 1/4): at
  // least n/4 - 3 sqrt(3n/16) of them but once in about 700. The scale is
  // the least k >= 1 that brings that many below.
  const double n = static_cast<double>(samples_.size());
  const long rank = static_cast<long>(std::floor(0.25 * n - 3.0 * std::sqrt(0.1875 * n)));
  if (rank < 1 || belowQuartile(1.0) >= rank) return 1.0;
  double low = 1.0, high = 2.0;
  while (belowQuartile(high) < rank && high < 1e12) high *= 2.0;
  // Bisection on log k to 0.1 %.
  while (high / low > 1.001) {
    const double mid = std::sqrt(low * high);
    (belowQuartile(mid) >= rank ? high : low) = mid;
  }
  return high;
}

}  // namespace core
}  // namespace agnc_pgo
