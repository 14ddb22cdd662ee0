// The noise scale estimated from pairs of neighbouring loop closures: 1 where
// the stated covariances are right or too wide, the factor by which they
// are too tight otherwise, and robust to the false pairs outliers make.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "agnc_pgo/core/chi_square.h"
#include "agnc_pgo/core/noise_scale.h"

using namespace agnc_pgo::core;

namespace {

// n chi-square(dof) draws times `scale`, and `false_pairs` far larger ones.
NoiseScale sampled(int dof, int n, double scale, int false_pairs = 0, unsigned seed = 1) {
  NoiseScale noise(dof);
  std::mt19937 rng(seed);
  std::chi_squared_distribution<double> chi2(dof);
  for (int i = 0; i < n; ++i) noise.add(scale * chi2(rng));
  for (int i = 0; i < false_pairs; ++i) noise.add(1e4 * (1.0 + chi2(rng)));
  return noise;
}

}  // namespace

TEST(NoiseScale, StatedRightOrTooWideStaysOne) {
  for (const int dof : {1, 2, 3}) {
    for (unsigned seed = 1; seed <= 20; ++seed) {
      EXPECT_EQ(sampled(dof, 2000, 1.0, 0, seed).estimate(), 1.0) << dof << " " << seed;
      EXPECT_EQ(sampled(dof, 2000, 0.05, 0, seed).estimate(), 1.0) << dof << " " << seed;
    }
  }
}

TEST(NoiseScale, TooTightIsFoundAsALowerBound) {
  for (const int dof : {1, 3}) {
    const double k = sampled(dof, 2000, 100.0).estimate();
    EXPECT_LT(k, 100.0) << dof;  // a lower confidence bound
    EXPECT_GT(k, 70.0) << dof;
  }
}

TEST(NoiseScale, FalsePairsRaiseItAtMostToTheQuantileTheyShiftTheQuartileTo) {
  // Half of the pairs false: the quartile reads chi^2's median.
  const double ratio = chiSquareQuantile(3, 0.5) / chiSquareQuantile(3, 0.25);
  const double k = sampled(3, 1000, 1.0, 1000).estimate();
  EXPECT_LE(k, ratio);
  // Too tight and contaminated: still found.
  EXPECT_GT(sampled(3, 1000, 100.0, 1000).estimate(), 70.0);
}

TEST(NoiseScale, NeedsEnoughPairsForTheBound) {
  EXPECT_EQ(sampled(3, 34, 100.0).estimate(), 1.0);
  EXPECT_GT(sampled(3, 64, 100.0).estimate(), 1.0);
}

TEST(NoiseScale, NonFinitePairsAreSkipped) {
  NoiseScale noise(3);
  noise.add(std::numeric_limits<double>::infinity());
  noise.add(std::numeric_limits<double>::quiet_NaN());
  noise.add(1.0);
  EXPECT_EQ(noise.samples(), 1);
}
