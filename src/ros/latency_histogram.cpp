#include "agnc_pgo/ros/latency_histogram.h"

#include <algorithm>
#include <cmath>

namespace agnc_pgo {
namespace ros_backend {
namespace {

constexpr double kLowest = 1e-3;    // [ms] first bin edge
constexpr double kHighest = 1e6;    // [ms] last bin edge (values above land in the last bin)
constexpr double kGrowth = 1.01;    // bin width ratio
const double kLogGrowth = std::log(kGrowth);
const int kBins = static_cast<int>(std::ceil(std::log(kHighest / kLowest) / kLogGrowth)) + 1;

}  // namespace

LatencyHistogram::LatencyHistogram() : bins_(static_cast<std::size_t>(kBins) + 1, 0) {}

int LatencyHistogram::binOf(double ms) const {
  if (!(ms >= kLowest)) return 0;
  const int bin = 1 + static_cast<int>(std::log(ms / kLowest) / kLogGrowth);
  return std::min(bin, kBins);
}

double LatencyHistogram::valueOf(int bin) const {
  if (bin == 0) return 0.0;
  return kLowest * std::pow(kGrowth, bin - 0.5);
}

void LatencyHistogram::add(double ms) {
  if (!(ms > 0.0)) ms = 0.0;
  ++bins_[static_cast<std::size_t>(binOf(ms))];
  ++count_;
  max_ = std::max(max_, ms);
}

void LatencyHistogram::clear() {
  std::fill(bins_.begin(), bins_.end(), 0);
  count_ = 0;
  max_ = 0.0;
}

double LatencyHistogram::percentile(double p) const {
  if (count_ == 0) return 0.0;
  if (p >= 100.0) return max_;
  // The sample of rank ceil(p/100 * count) (nearest-rank definition).
  const double wanted = std::max(1.0, std::ceil(std::max(0.0, p) / 100.0 * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (std::size_t bin = 0; bin < bins_.size(); ++bin) {
    seen += bins_[bin];
    if (static_cast<double>(seen) >= wanted) return std::min(valueOf(static_cast<int>(bin)), max_);
  }
  return max_;
}

}  // namespace ros_backend
}  // namespace agnc_pgo
