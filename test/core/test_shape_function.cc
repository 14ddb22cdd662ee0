// The AGNC B-spline shape function against ALGORITHM.md §3.
#include <gtest/gtest.h>

#include "agnc_pgo/core/shape_function.h"

using agnc_pgo::core::ShapeFunction;

TEST(ShapeFunction, GoldenMuPerStep) {
  const ShapeFunction& f = ShapeFunction::instance();
  const double expected[3][4] = {{0, 0.653704, 0.867037, 1},
                                 {0, 0.753395, 0.932901, 1},
                                 {0, 0.853086, 0.998765, 1}};
  const double alphas[3] = {0.0, 0.5, 1.0};
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR(f.muAtStep(alphas[a], k), expected[a][k], 1e-6) << "alpha " << alphas[a] << " step " << k;
}

TEST(ShapeFunction, StepsPastTheEndStayAtOne) {
  EXPECT_EQ(ShapeFunction::instance().muAtStep(0.3, 4), 1.0);
  EXPECT_EQ(ShapeFunction::instance().muAtStep(0.3, 10), 1.0);
}

TEST(ShapeFunction, TabulatedStepsEqualTheSplineEvaluation) {
  const ShapeFunction& f = ShapeFunction::instance();
  for (double alpha : {0.0, 0.25, 0.6, 1.0})
    for (int k = 0; k <= 3; ++k)
      EXPECT_NEAR(f.muAtStep(alpha, k), f.muAtParameter(alpha, k / 3.0), 1e-12);
}

TEST(ShapeFunction, MonotoneInStepAndAlpha) {
  const ShapeFunction& f = ShapeFunction::instance();
  for (double t = 0.0; t < 1.0; t += 0.05) {
    EXPECT_LE(f.muAtParameter(0.5, t), f.muAtParameter(0.5, t + 0.05) + 1e-12);
    EXPECT_LE(f.muAtParameter(0.0, t), f.muAtParameter(1.0, t) + 1e-12);
  }
}
