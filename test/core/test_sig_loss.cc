// SIG kernel against the golden table of ALGORITHM.md §2 (c = 3).
#include <gtest/gtest.h>

#include "agnc_pgo/core/sig_loss.h"

using agnc_pgo::core::SigLoss;

struct SigGolden {
  double mu, w1, w3, w10, rho3, rho10;
};

class SigLossGolden : public ::testing::TestWithParam<SigGolden> {};

TEST_P(SigLossGolden, WeightAndRhoMatchTheTable) {
  const SigGolden g = GetParam();
  const SigLoss loss(g.mu, 3.0);
  EXPECT_NEAR(loss.weight(1.0), g.w1, 1e-6);
  EXPECT_NEAR(loss.weight(3.0), g.w3, 1e-6);
  EXPECT_NEAR(loss.weight(10.0), g.w10, 1e-6);
  EXPECT_NEAR(loss.rho(3.0), g.rho3, 1e-6);
  EXPECT_NEAR(loss.rho(10.0), g.rho10, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Table, SigLossGolden,
                         ::testing::Values(SigGolden{0.0, 0.9, 0.9, 0.9, 4.05, 45.0},
                                           SigGolden{0.12, 0.8892, 0.860396, 0.821883, 3.931392, 41.908023},
                                           SigGolden{0.384, 0.86544, 0.732049, 0.513878, 3.576149, 30.279823},
                                           SigGolden{0.9648, 0.813168, 0.278486, 0.012207, 2.336967, 4.785429},
                                           SigGolden{1.0, 0.81, 0.25, 0.006818, 2.25, 4.128440}));

TEST(SigLoss, CeresTripleIsRhoWeightAndZeroCurvature) {
  SigLoss loss(0.384, 3.0);
  double rho[3];
  loss.Evaluate(9.0, rho);  // s = r^2 with r = 3
  EXPECT_NEAR(0.5 * rho[0], 3.576149, 1e-6);
  EXPECT_NEAR(rho[1], 0.732049, 1e-6);
  EXPECT_EQ(rho[2], 0.0);
}

TEST(SigLoss, FirstDerivativeMatchesFiniteDifference) {
  for (double mu : {0.0, 0.3, 0.7, 1.0}) {
    SigLoss loss(mu, 3.0);
    for (double s : {0.5, 4.0, 50.0}) {
      double lo[3], hi[3], mid[3];
      const double h = 1e-6 * s;
      loss.Evaluate(s - h, lo);
      loss.Evaluate(s + h, hi);
      loss.Evaluate(s, mid);
      EXPECT_NEAR(mid[1], (hi[0] - lo[0]) / (2 * h), 1e-6) << "mu " << mu << " s " << s;
    }
  }
}

TEST(SigLoss, MuIsMutableBetweenEvaluations) {
  SigLoss loss(0.0, 3.0);
  EXPECT_NEAR(loss.weight(10.0), 0.9, 1e-12);
  loss.setMu(1.0);
  EXPECT_NEAR(loss.weight(10.0), 0.006818, 1e-6);
  EXPECT_EQ(loss.mu(), 1.0);
}
