// Latency percentiles over a whole run in constant memory and constant time
// per query: a histogram with logarithmic bins (each 1 % wider than the last)
// from 1 us to 1e6 ms, plus the exact maximum. A quantile is exact to within
// one bin (relative error <= 1 %), whatever the number of samples, so a
// status message costs the same after a day as after a minute.
#pragma once

#include <cstdint>
#include <vector>

namespace agnc_pgo {
namespace ros_backend {

class LatencyHistogram {
 public:
  LatencyHistogram();

  void add(double milliseconds);  // NaN and negative values count as 0
  void clear();

  std::uint64_t count() const { return count_; }
  double max() const { return max_; }
  // p in [0, 100]; 0 when empty. p = 100 is the exact maximum.
  double percentile(double p) const;

 private:
  int binOf(double milliseconds) const;
  double valueOf(int bin) const;  // the bin's geometric centre

  std::vector<std::uint64_t> bins_;  // [0]: below the first edge
  std::uint64_t count_ = 0;
  double max_ = 0.0;
};

}  // namespace ros_backend
}  // namespace agnc_pgo
