#include "agnc_pgo/core/statistics.h"

#include <algorithm>

namespace agnc_pgo {
namespace core {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double position = std::min(100.0, std::max(0.0, p)) / 100.0 * (values.size() - 1);
  const size_t low = static_cast<size_t>(position);
  const size_t high = std::min(low + 1, values.size() - 1);
  const double fraction = position - low;
  return values[low] * (1.0 - fraction) + values[high] * fraction;
}

}  // namespace core
}  // namespace agnc_pgo
