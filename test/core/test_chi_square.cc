// Chi-square quantiles against ALGORITHM.md §3.
#include <gtest/gtest.h>

#include "agnc_pgo/core/chi_square.h"

using namespace agnc_pgo::core;

TEST(ChiSquare, GoldenQuantiles) {
  EXPECT_NEAR(chiSquareQuantile(3, 0.25), 1.212533, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(3, 0.90), 6.251389, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(3, 0.95), 7.814728, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(6, 0.25), 3.454599, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(6, 0.90), 10.644641, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(6, 0.95), 12.591587, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(2, 0.25), 0.575364, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(2, 0.90), 4.605170, 1e-6);
  EXPECT_NEAR(chiSquareQuantile(2, 0.95), 5.991465, 1e-6);
}

TEST(ChiSquare, CdfInvertsQuantile) {
  for (int dof : {2, 3, 6})
    for (double p : {0.25, 0.5, 0.9, 0.95}) EXPECT_NEAR(chiSquareCdf(dof, chiSquareQuantile(dof, p)), p, 1e-10);
  EXPECT_EQ(chiSquareCdf(3, 0.0), 0.0);
}

TEST(ChiSquare, ThresholdsForDof) {
  const ChiSquareThresholds t = ChiSquareThresholds::forDof(3);
  EXPECT_NEAR(t.q25, 1.212533, 1e-6);
  EXPECT_NEAR(t.q90, 6.251389, 1e-6);
  EXPECT_NEAR(t.q95, 7.814728, 1e-6);
}
