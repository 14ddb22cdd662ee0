// Latency statistics in constant memory: percentiles within 1 % of the exact
// ones over a million samples, the exact maximum, and nothing kept per sample.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "agnc_pgo/ros/latency_histogram.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

double exactPercentile(std::vector<double> values, double p) {
  std::sort(values.begin(), values.end());
  const std::size_t rank = static_cast<std::size_t>(std::ceil(p / 100.0 * values.size()));
  return values[std::max<std::size_t>(rank, 1) - 1];
}

TEST(LatencyHistogram, PercentilesWithinOnePercentOverAMillionSamples) {
  std::mt19937 rng(3);
  std::lognormal_distribution<double> latency(0.0, 1.5);  // ms, long tail
  std::vector<double> samples;
  LatencyHistogram histogram;
  for (int i = 0; i < 1000000; ++i) {
    const double ms = latency(rng);
    samples.push_back(ms);
    histogram.add(ms);
  }
  EXPECT_EQ(histogram.count(), 1000000u);
  for (double p : {1.0, 50.0, 95.0, 99.0, 99.9}) {
    const double exact = exactPercentile(samples, p);
    EXPECT_NEAR(histogram.percentile(p), exact, 0.01 * exact) << "p" << p;
  }
  EXPECT_EQ(histogram.percentile(100), *std::max_element(samples.begin(), samples.end()));
  EXPECT_EQ(histogram.max(), histogram.percentile(100));
}

TEST(LatencyHistogram, EmptyOddAndClearedInputs) {
  LatencyHistogram h;
  EXPECT_EQ(h.percentile(50), 0.0);
  h.add(std::nan(""));
  h.add(-3.0);
  h.add(1e12);  // beyond the last bin: counted there, max exact
  EXPECT_EQ(h.count(), 3u);
  EXPECT_EQ(h.percentile(50), 0.0);
  EXPECT_EQ(h.max(), 1e12);
  EXPECT_TRUE(std::isfinite(h.percentile(99)));
  h.clear();
  EXPECT_EQ(h.count(), 0u);
  h.add(2.0);
  EXPECT_NEAR(h.percentile(50), 2.0, 0.02);
}

}  // namespace
}  // namespace ros_backend
}  // namespace agnc_pgo
