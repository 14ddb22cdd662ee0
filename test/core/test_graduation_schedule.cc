// Each graduation rule on its own (ALGORITHM.md §3-4).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "agnc_pgo/core/graduation_schedule.h"
#include "agnc_pgo/core/sig_loss.h"

using namespace agnc_pgo::core;

namespace {

GncOptions::Schedule withSchedule(ScheduleKind kind) {
  GncOptions::Schedule o;
  o.kind = kind;
  return o;
}

// Runs one graduation at a constant distance; returns the mu of every solve.
std::vector<double> graduate(const GraduationSchedule& s, GraduationState* state, double distance) {
  std::vector<double> mus;
  s.start(state);
  while (state->graduating && mus.size() < 20) {
    s.advance(state, distance);
    mus.push_back(state->mu);
    s.finishStep(state);
  }
  return mus;
}

}  // namespace

TEST(GraduationSchedule, RisamLadder) {
  EXPECT_NEAR(GraduationSchedule::nextRisamMu(0.0), 0.12, 1e-12);
  EXPECT_NEAR(GraduationSchedule::nextRisamMu(0.12), 0.384, 1e-12);
  EXPECT_NEAR(GraduationSchedule::nextRisamMu(0.384), 0.9648, 1e-12);
  EXPECT_EQ(GraduationSchedule::nextRisamMu(0.9648), 1.0);
}

TEST(GraduationSchedule, NewRisamLoopClosureCostsSixSolves) {
  GraduationSchedule s(withSchedule(ScheduleKind::kRisam), 3);
  GraduationState state;
  const std::vector<double> mus = graduate(s, &state, 2.0);
  ASSERT_EQ(mus.size(), 6u);
  const double expected[6] = {0, 0.12, 0.384, 0.9648, 1, 1};
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(mus[k], expected[k], 1e-12);
}

TEST(GraduationSchedule, NewAgncLoopClosureCostsFiveSolves) {
  GraduationSchedule s(withSchedule(ScheduleKind::kAgncFixed), 3);
  GraduationState state;
  const std::vector<double> mus = graduate(s, &state, 2.0);
  ASSERT_EQ(mus.size(), 5u);
  const double expected[5] = {0, 0.753395, 0.932901, 1, 1};
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(mus[k], expected[k], 1e-6);
}

TEST(GraduationSchedule, AdaptiveAlphaFollowsThePaper) {
  GraduationSchedule s(withSchedule(ScheduleKind::kAgnc), 3);
  const ChiSquareThresholds& t = s.thresholds();
  EXPECT_EQ(s.adaptiveAlpha(t.q25 - 1e-9), 0.0);
  EXPECT_EQ(s.adaptiveAlpha(t.q90), 1.0);
  EXPECT_NEAR(s.adaptiveAlpha(0.5 * (t.q25 + t.q90)), 0.5, 1e-12);
  // Confident inlier: gradual curve; confident outlier: rapid curve.
  GraduationState inlier, outlier;
  EXPECT_NEAR(graduate(s, &inlier, 0.5)[1], 0.653704, 1e-6);
  EXPECT_NEAR(graduate(s, &outlier, 50.0)[1], 0.853086, 1e-6);
}

TEST(GraduationSchedule, ReferenceAlphaJumpsAtBothBandEdges) {
  GncOptions::Schedule o = withSchedule(ScheduleKind::kAgnc);
  o.reference_alpha_direction = true;
  GraduationSchedule s(o, 3);
  const ChiSquareThresholds& t = s.thresholds();
  EXPECT_EQ(s.referenceAlpha(t.q25 - 1e-6), 0.0);
  EXPECT_NEAR(s.referenceAlpha(t.q25 + 1e-9), 1.0, 1e-6);   // rapid just inside
  EXPECT_NEAR(s.referenceAlpha(t.q90 - 1e-9), 0.0, 1e-6);   // gradual just inside
  EXPECT_EQ(s.referenceAlpha(t.q90), 1.0);
}

TEST(GraduationSchedule, AgncAdaptationJumpsToOneForOutliers) {
  GraduationSchedule s(withSchedule(ScheduleKind::kAgnc), 3);
  GraduationState state;
  s.adaptInitial(&state, 100.0);
  EXPECT_EQ(state.init_step, 3);
  // Next restart: mu = 1 at once, two solves.
  const std::vector<double> mus = graduate(s, &state, 100.0);
  ASSERT_EQ(mus.size(), 2u);
  EXPECT_EQ(mus[0], 1.0);
  s.adaptInitial(&state, 0.1);
  EXPECT_EQ(state.init_step, 0);
  s.adaptInitial(&state, 3.0);  // inside the band: unchanged
  EXPECT_EQ(state.init_step, 0);
}

TEST(GraduationSchedule, RisamAdaptationMovesMuInit) {
  GraduationSchedule s(withSchedule(ScheduleKind::kRisam), 3);
  GraduationState state;
  s.adaptInitial(&state, 100.0);
  EXPECT_NEAR(state.mu_init, 0.12, 1e-12);
  s.adaptInitial(&state, 100.0);
  EXPECT_NEAR(state.mu_init, 0.384, 1e-12);
  s.adaptInitial(&state, 0.1);
  EXPECT_NEAR(state.mu_init, 0.284, 1e-12);
  const std::vector<double> mus = graduate(s, &state, 2.0);
  EXPECT_NEAR(mus[0], 0.284, 1e-12);
}

TEST(GraduationSchedule, DistanceConventions) {
  GncOptions::Schedule o;
  o.distance = DistanceConvention::kReference;
  EXPECT_EQ(GraduationSchedule(o, 3).distanceOf(3.0), 3.0);
  o.distance = DistanceConvention::kSquared;
  EXPECT_EQ(GraduationSchedule(o, 3).distanceOf(3.0), 9.0);
  // Final classification at q(0.95) of the convention's value.
  EXPECT_TRUE(GraduationSchedule(o, 3).isInlier(7.8));
  EXPECT_FALSE(GraduationSchedule(o, 3).isInlier(7.82));
}

TEST(GraduationSchedule, ClassificationByWeightAgreesWithTheKernelWeight) {
  GncOptions::Schedule o;  // distance: reference
  o.classification = Classification::kWeight;
  const GraduationSchedule s(o, 6);
  // 3-D, 10 sigma off: r = 10 < q(0.95) = 12.59, so the reference test says
  // inlier, while its weight at mu = 1 is 0.0068.
  EXPECT_TRUE(s.isInlier(s.distanceOf(10.0)));
  EXPECT_FALSE(s.classifiesAsInlier(10.0));
  EXPECT_DOUBLE_EQ(s.classificationDistance(10.0), 100.0);
  // The gate r^2 = q(0.95) is where the weight crosses that of the gate.
  const SigLoss loss(/*mu=*/1.0, o.shape_c);
  const double gate = std::sqrt(s.thresholds().q95);
  auto weight = [&](double r) { return loss.weight(r); };
  for (double r : {0.5, 1.0, 2.0, 3.0, 3.5, 4.0, 7.0, 10.0})
    EXPECT_EQ(s.classifiesAsInlier(r), weight(r) > weight(gate)) << "r = " << r;
  // The reference code's classification stays available.
  o.classification = Classification::kDistance;
  EXPECT_TRUE(GraduationSchedule(o, 6).classifiesAsInlier(10.0));
  EXPECT_DOUBLE_EQ(GraduationSchedule(o, 6).classificationDistance(10.0), 10.0);
  EXPECT_EQ(parseClassification("distance"), Classification::kDistance);
  EXPECT_EQ(toString(parseClassification("weight")), "weight");
  EXPECT_THROW(parseClassification("r2"), std::invalid_argument);
}

TEST(GraduationSchedule, NoneNeverGraduates) {
  GraduationSchedule s(withSchedule(ScheduleKind::kNone), 3);
  GraduationState state;
  s.start(&state);
  EXPECT_FALSE(state.graduating);
}

TEST(GncOptions, ParsingAndValidation) {
  EXPECT_EQ(parseSchedule("agnc-fixed"), ScheduleKind::kAgncFixed);
  EXPECT_THROW(parseSchedule("fast"), std::invalid_argument);
  EXPECT_EQ(parseResetPolicy("all"), ResetPolicy::kAll);
  EXPECT_EQ(toString(parseDistanceConvention("squared")), "squared");
  GncOptions o;
  o.schedule.fixed_alpha = 1.5;
  EXPECT_THROW(validate(o), std::invalid_argument);
  // A relation between two fields: the trust region may not start above its cap.
  GncOptions radii;
  radii.solver.max_trust_region_radius = 0.5 * radii.solver.trust_region_radius;
  EXPECT_THROW(validate(radii), std::invalid_argument);
}
