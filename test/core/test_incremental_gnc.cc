// The incremental engine: its contract (no solve without loop closures, bad
// input leaves the graph intact, overrides) and end-to-end replays with
// injected outliers in 2D (ring) and 3D (smallGrid3D).
#include <gtest/gtest.h>

#include "shared_datasets.h"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <string>

#include "agnc_pgo/core/batch_solver.h"
#include "agnc_pgo/core/chi_square.h"
#include "agnc_pgo/core/g2o_io.h"
#include "agnc_pgo/core/incremental_gnc.h"
#include "agnc_pgo/eval/incremental_log.h"
#include "agnc_pgo/eval/metrics.h"
#include "agnc_pgo/eval/outlier_injection.h"
#include "agnc_pgo/eval/replay.h"

using namespace agnc_pgo::core;

namespace {

std::string dataset(const std::string& name) {
  return std::string(AGNC_PGO_SHARED_DIR) + "/datasets/" + name;
}

Edge edge(int from, int to, const Pose& z, double information = 100.0) {
  Edge e;
  e.from = from;
  e.to = to;
  e.measurement = z;
  e.information = information * Eigen::Matrix3d::Identity();
  return e;
}

// A square loop of four poses with odometry only.
std::unique_ptr<IncrementalGnc> squareEngine(const GncOptions& options) {
  auto owned = std::make_unique<IncrementalGnc>(2, options);
  IncrementalGnc& engine = *owned;
  engine.addFirstPose(Pose::fromSE2(0, 0, 0), 1e6 * Eigen::Matrix3d::Identity());
  for (int i = 0; i < 4; ++i) engine.addOdometry(edge(i, i + 1, Pose::fromSE2(1, 0, M_PI / 2)));
  return owned;
}

// Outliers are placed against the outlier-free optimum (the geometry the
// engine can know), as the replay tool does; `reference` receives it.
PoseGraph withOutliers(const PoseGraph& graph, const std::string& name, double percent,
                       std::uint64_t seed, PoseGraph* reference = nullptr,
                       OutlierMode mode = OutlierMode::kRandom) {
  PoseGraph optimum = graph;
  optimizeBatch(&optimum);
  OutlierOptions outliers;
  outliers.percent = percent;
  outliers.seed = seed;
  outliers.mode = mode;
  PoseGraph out = injectOutliers(graph, optimum, name, outliers);
  if (reference != nullptr) *reference = std::move(optimum);
  return out;
}

ReplayResult replayWithOutliers(const std::string& name, double percent, const GncOptions& gnc) {
  const IncrementalLog log = logFromGraph(withOutliers(readG2o(dataset(name)), name, percent, 3), name);
  ReplayOptions options;
  options.gnc = gnc;
  return replay(log, options);
}

}  // namespace

TEST(IncrementalGnc, OdometryNeedsNoSolve) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  const UpdateStats stats = engine.update();
  EXPECT_EQ(stats.iterations, 0);
  EXPECT_EQ(engine.numPoses(), 5);
  // Composed odometry: back at the origin after four quarter turns.
  EXPECT_NEAR(engine.pose(4).translation.norm(), 0.0, 1e-12);
}

// The square with odometry so stiff that a loop closure cannot move it: a
// loop closure 3 sigma off stays there and graduates the whole ladder.
std::unique_ptr<IncrementalGnc> stiffSquareEngine(const GncOptions& options) {
  auto owned = std::make_unique<IncrementalGnc>(2, options);
  owned->addFirstPose(Pose::fromSE2(0, 0, 0), 1e6 * Eigen::Matrix3d::Identity());
  for (int i = 0; i < 4; ++i) owned->addOdometry(edge(i, i + 1, Pose::fromSE2(1, 0, M_PI / 2), 1e6));
  return owned;
}

TEST(IncrementalGnc, NewLoopClosureCostsFiveGncStepsWithAgncAndSixWithRisam) {
  for (const auto& [kind, steps] : {std::pair<ScheduleKind, int>{ScheduleKind::kAgncFixed, 5},
                                    std::pair<ScheduleKind, int>{ScheduleKind::kRisam, 6}}) {
    GncOptions options;
    options.schedule.kind = kind;
    auto owned = stiffSquareEngine(options);
    IncrementalGnc& engine = *owned;
    engine.addLoopClosure(edge(4, 0, Pose::fromSE2(0.3, 0, 0)));  // r = 3
    const UpdateStats stats = engine.update();
    EXPECT_EQ(stats.gnc_steps, steps) << toString(kind);
    EXPECT_NEAR(engine.loopClosures()[0].distance, 3.0, 0.01);
    EXPECT_TRUE(engine.loopClosures()[0].inlier);  // 3 < q(0.95) = 7.81 (reference convention)
    EXPECT_EQ(engine.loopClosures()[0].graduation.mu, 1.0);
  }
}

TEST(IncrementalGnc, ConsistentLoopClosureIsAcceptedOnArrival) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  engine.addLoopClosure(edge(4, 0, Pose::fromSE2(0, 0, 0)));
  const UpdateStats stats = engine.update();
  EXPECT_EQ(stats.gnc_steps, 0);  // already consistent: no graduation at all
  EXPECT_GE(stats.iterations, 1);  // but the estimate is still brought up to date
  EXPECT_EQ(engine.loopClosures()[0].graduation.mu, 1.0);
  EXPECT_FALSE(engine.loopClosures()[0].graduation.graduating);
  EXPECT_TRUE(engine.loopClosures()[0].inlier);
}

TEST(IncrementalGnc, LoopClosureThatLandsStopsGraduatingOnceConsistent) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  engine.addLoopClosure(edge(4, 0, Pose::fromSE2(0.2, 0, 0)));  // r = 2: graduates
  const UpdateStats stats = engine.update();
  // The first step lands it (the square absorbs 0.2 m), after which it is a
  // confident inlier whose weight no longer depends on mu.
  EXPECT_EQ(stats.gnc_steps, 1);
  EXPECT_EQ(engine.loopClosures()[0].graduation.mu, 1.0);
  EXPECT_TRUE(engine.loopClosures()[0].inlier);
  EXPECT_LT(engine.loopClosures()[0].distance, 1.0);
}

// A loop closure kept with a residual its covariance explains is decided:
// from the next solve on it counts at full weight, so the estimate is the
// least-squares one over what was kept (Geman-McClure's weight, 0.81 at
// 1 sigma, would hold the map towards the odometry); the objective that
// judges the decisions still prices it at mu = 1.
TEST(IncrementalGnc, KeptLoopClosureCountsAtFullWeight) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  const Edge loop = edge(4, 0, Pose::fromSE2(0.5, 0, 0.1), 25.0);
  engine.addLoopClosure(loop);
  engine.update();
  engine.optimize();
  const LoopClosure& kept = engine.loopClosures()[0];
  ASSERT_TRUE(kept.inlier);
  EXPECT_TRUE(kept.full_weight);
  EXPECT_EQ(kept.weight, 1.0);

  PoseGraph graph;
  graph.dimension = 2;
  graph.poses = engine.poses();
  for (int i = 0; i < 4; ++i) graph.edges.push_back(edge(i, i + 1, Pose::fromSE2(1, 0, M_PI / 2)));
  graph.edges.push_back(loop);
  graph.edges.back().kind = EdgeKind::kLoopClosure;
  optimizeBatch(&graph);
  for (int i = 0; i < engine.numPoses(); ++i)
    EXPECT_LT((engine.pose(i).translation - graph.poses[i].translation).norm(), 1e-3) << i;  // GM: up to 0.027
}

// A far outlier is not decided into the estimate: it stays on the kernel.
TEST(IncrementalGnc, RejectedLoopClosureStaysOnTheKernel) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  engine.addLoopClosure(edge(4, 0, Pose::fromSE2(30, 0, 0)));
  engine.update();
  EXPECT_FALSE(engine.loopClosures()[0].inlier);
  EXPECT_FALSE(engine.loopClosures()[0].full_weight);
  EXPECT_LT(engine.loopClosures()[0].weight, 1e-3);
}

// Along a straight chain a loop closure's correction is linear in the
// poses: the first Gauss-Newton step reaches the minimum and the model
// predicted it exactly, so it is also the last (judged by the mean step
// alone, a second iteration was needed to see the step small).
TEST(IncrementalGnc, AnExactModelConvergesInOneIteration) {
  GncOptions options;
  options.schedule.kind = ScheduleKind::kNone;
  IncrementalGnc engine(2, options);
  engine.addFirstPose(Pose::fromSE2(0, 0, 0), 1e6 * Eigen::Matrix3d::Identity());
  for (int i = 0; i < 4; ++i) engine.addOdometry(edge(i, i + 1, Pose::fromSE2(1, 0, 0)));
  engine.addLoopClosure(edge(0, 4, Pose::fromSE2(4.3, 0, 0)));
  const UpdateStats stats = engine.update();
  EXPECT_EQ(stats.iterations, 1);
  EXPECT_TRUE(stats.converged);
  // Five equal constraints around the cycle share the 0.3 m.
  EXPECT_NEAR(engine.pose(4).translation.x(), 4.24, 1e-6);
}

TEST(IncrementalGnc, ImplausibleLoopClosureIsRejectedOnArrivalWithoutASolve) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  const Poses before = engine.poses();
  engine.addLoopClosure(edge(3, 1, Pose::fromSE2(25.0, -10.0, 2.0)));
  const UpdateStats stats = engine.update();
  EXPECT_EQ(stats.gnc_steps, 0);
  EXPECT_EQ(stats.iterations, 0);
  const LoopClosure& loop = engine.loopClosures()[0];
  EXPECT_FALSE(loop.inlier);
  EXPECT_TRUE(loop.uncorroborated);  // far, and no neighbour agrees with it
  EXPECT_LT(loop.weight, 1e-3);
  EXPECT_EQ(loop.graduation.init_step, 3);  // a later restart begins at mu = 1
  for (int i = 0; i < engine.numPoses(); ++i) EXPECT_EQ(engine.pose(i).translation, before[i].translation);
}

// A straight corridor of 50 poses, 1 m apart, odometry only.
std::unique_ptr<IncrementalGnc> corridorEngine(const GncOptions& options) {
  auto owned = std::make_unique<IncrementalGnc>(2, options);
  owned->addFirstPose(Pose::fromSE2(0, 0, 0), 1e6 * Eigen::Matrix3d::Identity());
  for (int i = 0; i < 49; ++i) owned->addOdometry(edge(i, i + 1, Pose::fromSE2(1, 0, 0)));
  return owned;
}

TEST(IncrementalGnc, WindowReachesAtMostMaxWindowPosesBackFromTheNewerEndpoint) {
  GncOptions options;
  options.window.max_poses = 10;
  options.window.global_refinement = false;  // to see what the window alone moved
  auto owned = corridorEngine(options);
  IncrementalGnc& engine = *owned;
  const Poses before = engine.poses();
  // Pose 49 seen 0.3 m short of where odometry puts it relative to pose 2.
  engine.addLoopClosure(edge(2, 49, Pose::fromSE2(46.7, 0, 0)));
  const UpdateStats stats = engine.update();
  EXPECT_EQ(stats.first_variable, 40);  // 49 + 1 - 10, not the older endpoint 2
  for (int i = 0; i < 40; ++i)
    EXPECT_EQ(engine.pose(i).translation, before[i].translation) << "pose " << i << " is held fixed";
  EXPECT_LT(engine.pose(49).translation.x(), 48.9);  // the window took the correction
  EXPECT_TRUE(engine.loopClosures()[0].inlier);

  // A loop closure between two old poses: the window ends at its newer one.
  engine.addLoopClosure(edge(5, 20, Pose::fromSE2(15.1, 0, 0)));
  EXPECT_EQ(engine.update().first_variable, 11);  // 20 + 1 - 10
}

// Anytime: the first estimate is the window's result, reported before the
// whole graph follows it; the update ends where it would without the report.
TEST(IncrementalGnc, FirstEstimateIsTheWindowsResultBeforeTheWholeGraphFollows) {
  GncOptions options;
  options.window.max_poses = 10;
  GncOptions window_only = options;
  window_only.window.global_refinement = false;
  auto reported = corridorEngine(options);
  auto silent = corridorEngine(options);
  auto unrefined = corridorEngine(window_only);
  const Edge short_by_30cm = edge(2, 49, Pose::fromSE2(46.7, 0, 0));
  for (auto* engine : {reported.get(), silent.get(), unrefined.get()}) engine->addLoopClosure(short_by_30cm);

  int calls = 0;
  Poses first;
  const UpdateStats stats = reported->update([&] {
    ++calls;
    first = reported->poses();
  });
  silent->update();
  unrefined->update();
  EXPECT_EQ(calls, 1);
  EXPECT_GT(stats.refinement_iterations, 0);
  ASSERT_EQ(first.size(), 50u);
  for (int i = 0; i < 50; ++i) {
    EXPECT_EQ(first[i].translation, unrefined->pose(i).translation) << "pose " << i;
    EXPECT_EQ(reported->pose(i).translation, silent->pose(i).translation) << "pose " << i;
  }
  // The refinement after it moved the older poses too.
  EXPECT_GT((reported->pose(20).translation - first[20].translation).norm(), 1e-3);
  EXPECT_TRUE(reported->loopClosures()[0].inlier);

  // Nothing left after the window: nothing to report early.
  unrefined->addLoopClosure(edge(40, 49, Pose::fromSE2(9.0, 0, 0)));
  unrefined->update([&] { ++calls; });
  EXPECT_EQ(calls, 1);
}

TEST(IncrementalGnc, UnboundedWindowStartsAtTheOlderEndpoint) {
  GncOptions options;
  options.window.max_poses = 0;
  auto owned = corridorEngine(options);
  owned->addLoopClosure(edge(2, 49, Pose::fromSE2(46.7, 0, 0)));
  EXPECT_EQ(owned->update().first_variable, 2);
}

TEST(IncrementalGnc, GrossOutlierIsRejectedAndLeavesTheEstimate) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  engine.addLoopClosure(edge(4, 0, Pose::fromSE2(0, 0, 0)));
  engine.update();
  const Pose before = engine.pose(2);
  engine.addLoopClosure(edge(3, 1, Pose::fromSE2(25.0, -10.0, 2.0)));
  engine.update();
  EXPECT_FALSE(engine.loopClosures()[1].inlier);
  EXPECT_LT(engine.loopClosures()[1].weight, 0.01);
  EXPECT_LT((engine.pose(2).translation - before.translation).norm(), 1e-3);
}

// A loop closure rejected at mu = 1 goes dormant whatever its weight there:
// 20 sigma off, its Geman-McClure weight is still 5e-4, and kept in the
// cost that tail would pull the square by millimetres.
TEST(IncrementalGnc, ARejectedLoopClosureDoesNotPullTheMap) {
  auto with_outlier = squareEngine(GncOptions());
  auto without = squareEngine(GncOptions());
  for (IncrementalGnc* engine : {with_outlier.get(), without.get()}) {
    engine->addLoopClosure(edge(4, 0, Pose::fromSE2(0, 0, 0)));
    engine->update();
  }
  // The true relative pose is (1, 1, pi); this one is 2 m (20 sigma) off.
  with_outlier->addLoopClosure(edge(3, 1, Pose::fromSE2(3.0, 1.0, M_PI)));
  with_outlier->update();
  for (IncrementalGnc* engine : {with_outlier.get(), without.get()}) engine->optimize(20);
  const LoopClosure& outlier = with_outlier->loopClosures()[1];
  EXPECT_FALSE(outlier.inlier);
  EXPECT_GT(outlier.weight, 1e-4);  // far above dormant_weight
  EXPECT_TRUE(outlier.dormant);
  for (int i = 0; i < 5; ++i)
    EXPECT_LT((with_outlier->pose(i).translation - without->pose(i).translation).norm(), 1e-9) << i;
}

TEST(IncrementalGnc, BadInputIsRejectedAndTheGraphStaysIntact) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  Edge nan_edge = edge(1, 3, Pose::fromSE2(0, 0, 0));
  nan_edge.measurement.translation.x() = std::nan("");
  EXPECT_THROW(engine.addLoopClosure(nan_edge), std::invalid_argument);
  EXPECT_THROW(engine.addLoopClosure(edge(1, 9, Pose())), std::invalid_argument);
  Edge not_pd = edge(1, 3, Pose());
  not_pd.information(2, 2) = -1.0;
  EXPECT_THROW(engine.addLoopClosure(not_pd), std::invalid_argument);
  Edge zero_quaternion = edge(1, 3, Pose());
  zero_quaternion.measurement.rotation.coeffs().setZero();
  EXPECT_THROW(engine.addLoopClosure(zero_quaternion), std::invalid_argument);
  EXPECT_THROW(engine.addOdometry(edge(2, 7, Pose())), std::invalid_argument);
  EXPECT_EQ(engine.numPoses(), 5);
  EXPECT_TRUE(engine.loopClosures().empty());
  EXPECT_EQ(engine.update().iterations, 0);
}

TEST(IncrementalGnc, ForcedOutlierChangesClassificationAndEstimate) {
  auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
  engine.addLoopClosure(edge(4, 0, Pose::fromSE2(0.3, 0, 0)));
  engine.update();
  const Pose with_loop = engine.pose(4);
  engine.setOverride(0, LoopOverride::kForceOutlier);
  engine.update();
  EXPECT_FALSE(engine.loopClosures()[0].inlier);
  EXPECT_EQ(engine.loopClosures()[0].weight, 0.0);
  EXPECT_GT((engine.pose(4).translation - with_loop.translation).norm(), 0.05);
  engine.setOverride(0, LoopOverride::kAuto);
  engine.update();
  EXPECT_TRUE(engine.loopClosures()[0].inlier);
}

TEST(IncrementalGnc, DeterministicForTheSameInput) {
  auto run = []() {
    auto owned = squareEngine(GncOptions());
  IncrementalGnc& engine = *owned;
    engine.addLoopClosure(edge(4, 0, Pose::fromSE2(0.1, 0.05, 0.01)));
    engine.addLoopClosure(edge(3, 0, Pose::fromSE2(4.0, 4.0, 1.0)));
    engine.update();
    return engine.poses();
  };
  const Poses a = run(), b = run();
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].translation, b[i].translation);
}

TEST(IncrementalGncEndToEnd, CsailWithThirtyPercentOutliers) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const ReplayResult result = replayWithOutliers("csail.g2o", 30.0, GncOptions());
  EXPECT_EQ(result.loop_closures.size(), 128u + 54u);  // floor(30 * 128 / 70) = 54
  EXPECT_DOUBLE_EQ(result.counts.precision(), 1.0);
  EXPECT_GE(result.counts.recall(), 0.98);
}

// The repository's generated test worlds (scripts/make_scaling_graph.py,
// 400 poses, 2D and 3D, with ground truth; built with the tests), so that
// a clone without ../shared runs the engine end to end too. 30 % outliers
// in each of the four modes a front-end fails in: every true loop closure
// kept, every outlier rejected, and the map as close to the ground truth as
// the engine's outlier-free run (within 10 %).
TEST(IncrementalGncEndToEnd, GeneratedWorldsWithOutliersInEveryMode) {
  for (const std::string name : {"grid2d_400_seed1", "grid3d_400_seed1"}) {
    const std::string world = std::string(AGNC_PGO_TEST_WORLD_DIR) + "/" + name;
    const PoseGraph graph = readG2o(world + ".g2o");
    const PoseGraph truth = readG2o(world + "_gt.g2o");
    ASSERT_GT(graph.numLoopClosures(), 100) << name;
    const ReplayResult clean = replay(logFromGraph(graph, name), ReplayOptions());
    const double clean_ate = absoluteTrajectoryError(clean.estimate, truth.poses, graph.dimension);
    EXPECT_DOUBLE_EQ(clean.counts.recall(), 1.0) << name;
    for (const OutlierMode mode : {OutlierMode::kRandom, OutlierMode::kLocal, OutlierMode::kRandomGrouped,
                                   OutlierMode::kLocalGrouped}) {
      const PoseGraph noisy = withOutliers(graph, name, 30.0, 1, nullptr, mode);
      const ReplayResult result = replay(logFromGraph(noisy, name), ReplayOptions());
      const std::string cell = name + ", " + toString(mode);
      EXPECT_GT(result.counts.true_negative, 60) << cell;  // floor(30 * ~160 / 70) outliers
      EXPECT_DOUBLE_EQ(result.counts.precision(), 1.0) << cell;
      EXPECT_DOUBLE_EQ(result.counts.recall(), 1.0) << cell;
      EXPECT_LE(absoluteTrajectoryError(result.estimate, truth.poses, graph.dimension), 1.1 * clean_ate) << cell;
    }
  }
}

// The generated worlds state their noise as it is. Stated 100 times too
// tight in rotation (variance), every loop closure costs more to keep than
// the kernel lets a rejection cost: the engine has to see from the pairs of
// neighbouring loop closures that the rotations are noisier than stated.
// With this world's 160 loop closures the lower confidence bound is loose
// (noise_scale.h), in 2-D (one rotational degree of freedom) most: the
// scale found is a fraction of 100 and some true loop closures stay out
// (without it, all of them). Still too tight after the scale, only part of
// the true loop closures pass the chi-square gate, and those count at full
// weight: outlier-free recall 0.60 (2-D) and 0.87 (3-D), against 0.70 and
// 0.93 when every kept loop closure stayed on Geman-McClure's weights.
TEST(IncrementalGncEndToEnd, RotationNoiseStatedTooTightIsWidenedFromThePairs) {
  struct World {
    std::string name;
    double min_rotation_scale, min_recall;
  };
  for (const World& w : {World{"grid2d_400_seed1", 5.0, 0.55}, World{"grid3d_400_seed1", 20.0, 0.85}}) {
    const std::string& name = w.name;
    const std::string world = std::string(AGNC_PGO_TEST_WORLD_DIR) + "/" + name;
    const PoseGraph graph = readG2o(world + ".g2o");
    const ReplayResult stated_right = replay(logFromGraph(graph, name), ReplayOptions());
    EXPECT_EQ(stated_right.noise_scale, Eigen::VectorXd::Ones(graph.tangentDimension())) << name;

    const int t = graph.dimension == 2 ? 2 : 3;
    const int n = graph.tangentDimension();
    Eigen::VectorXd d = Eigen::VectorXd::Ones(n);
    d.tail(n - t).setConstant(10.0);
    for (const double percent : {0.0, 30.0}) {
      // The front-end states every loop closure alike, false ones too.
      PoseGraph input = percent > 0.0 ? withOutliers(graph, name, percent, 1) : graph;
      for (Edge& e : input.edges) e.information = d.asDiagonal() * e.information * d.asDiagonal();
      const ReplayResult result = replay(logFromGraph(input, name), ReplayOptions());
      const std::string cell = name + ", " + std::to_string(percent) + " %";
      EXPECT_GT(result.noise_scale(n - 1), w.min_rotation_scale) << cell;
      EXPECT_LT(result.noise_scale(0), result.noise_scale(n - 1)) << cell;
      EXPECT_DOUBLE_EQ(result.counts.precision(), 1.0) << cell;
      EXPECT_GE(result.counts.recall(), w.min_recall) << cell;
    }
  }
}

TEST(IncrementalGncEndToEnd, SmallGrid3dWithTwentyPercentOutliers) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const ReplayResult result = replayWithOutliers("smallGrid3D.g2o", 20.0, GncOptions());
  EXPECT_EQ(result.loop_closures.size(), 173u + 43u);  // floor(20 * 173 / 80) = 43
  EXPECT_DOUBLE_EQ(result.counts.precision(), 1.0);
  EXPECT_GE(result.counts.recall(), 0.98);
}

// The first `n` poses of a dataset and the edges among them.
static PoseGraph firstPoses(const PoseGraph& graph, int n) {
  PoseGraph out;
  out.dimension = graph.dimension;
  out.poses.assign(graph.poses.begin(), graph.poses.begin() + n);
  for (const Edge& e : graph.edges)
    if (e.from < n && e.to < n) out.edges.push_back(e);
  return out;
}

// A front-end that delivers a whole graph at once (or a back-end that fell
// behind): every loop closure graduates in one update. The ring's loop
// closures need a large correction; the trust region must let it through.
TEST(IncrementalGncEndToEnd, RingLoopClosuresBatchedIntoOneUpdate) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph graph = withOutliers(readG2o(dataset("ring.g2o")), "ring", 10.0, 2);
  IncrementalGnc engine(2, GncOptions());
  engine.addFirstPose(graph.poses[0], 1e6 * Eigen::MatrixXd::Identity(3, 3));
  std::vector<Edge> odometry;
  for (const Edge& e : graph.edges)
    if (e.kind == EdgeKind::kOdometry) odometry.push_back(e);
  std::sort(odometry.begin(), odometry.end(), [](const Edge& a, const Edge& b) { return a.to < b.to; });
  for (const Edge& e : odometry) engine.addOdometry(e);
  for (const Edge& e : graph.edges)
    if (e.kind == EdgeKind::kLoopClosure) engine.addLoopClosure(e);
  engine.update();
  std::vector<bool> is_outlier, kept;
  for (const LoopClosure& loop : engine.loopClosures()) {
    is_outlier.push_back(loop.edge.is_outlier);
    kept.push_back(loop.inlier);
  }
  const ClassificationCounts counts = classify(is_outlier, kept);
  EXPECT_EQ(counts.true_positive, 26);  // every true loop closure of the ring
  EXPECT_EQ(counts.false_negative, 0);
  EXPECT_EQ(counts.false_positive, 0);
}

// A new outlier's first, nearly quadratic GNC step must not fold the map
// (a trust region carried over from earlier updates let it: ATE 10.7 m on
// these 1200 poses of M3500 at 30 %, against 0.79 m without outliers).
TEST(IncrementalGncEndToEnd, OutliersDoNotFoldManhattan) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  PoseGraph reference;
  const PoseGraph graph = withOutliers(firstPoses(readG2o(dataset("manhattanOlson3500.g2o")), 1200),
                                       "manhattanOlson3500", 30.0, 1, &reference);
  const ReplayResult result = replay(logFromGraph(graph, "m1200"), ReplayOptions());
  EXPECT_DOUBLE_EQ(result.counts.precision(), 1.0);
  EXPECT_GE(result.counts.recall(), 0.99);
  EXPECT_LT(absoluteTrajectoryError(result.estimate, reference.poses, 2), 0.1);
}

// Perceptual aliasing: groups of ten false loop closures that agree with
// each other (one shared wrong measurement). Each new member corroborates
// the rejected ones, so the group is landed again and again; graduation
// from the convex start over the whole cycle can end in a minimum where the
// map bends towards the group and true loop closures are rejected. A trial
// stands only if it ends lower on the robust objective than the map without
// it. Measured: random-grouped P = R = 1, ATE 0.028 m; local-grouped 0.140 m
// (before the check: P 0.996 / R 0.983, 11.0 m and P 0.982, 2.27 m).
TEST(IncrementalGncEndToEnd, GroupsOfFalseLoopClosuresDoNotFoldManhattan) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  for (const OutlierMode mode : {OutlierMode::kRandomGrouped, OutlierMode::kLocalGrouped}) {
    PoseGraph reference;
    const PoseGraph graph = withOutliers(firstPoses(readG2o(dataset("manhattanOlson3500.g2o")), 1200),
                                         "manhattanOlson3500", 30.0, 1, &reference, mode);
    const ReplayResult result = replay(logFromGraph(graph, "m1200"), ReplayOptions());
    const double ate = absoluteTrajectoryError(result.estimate, reference.poses, 2);
    EXPECT_DOUBLE_EQ(result.counts.precision(), 1.0) << toString(mode);
    EXPECT_DOUBLE_EQ(result.counts.recall(), 1.0) << toString(mode);
    EXPECT_LT(ate, 0.2) << toString(mode);
  }
}

// M3500 with local-grouped outliers at 30 % (injected as agnc_pgo_replay
// does), replayed with the default options: the result, and the ATE of its
// estimate against the outlier-free optimum (global start).
struct LocalGroupedManhattan {
  ReplayResult result;
  double ate_vs_optimum;
};

LocalGroupedManhattan replayLocalGroupedManhattan(int seed) {
  const PoseGraph graph = readG2o(dataset("manhattanOlson3500.g2o"));
  OutlierOptions outliers;
  outliers.percent = 30.0;
  outliers.seed = seed;
  outliers.mode = OutlierMode::kLocalGrouped;
  const IncrementalLog log =
      logFromGraph(injectOutliersAgainstOptimum(graph, "manhattanOlson3500", outliers), "manhattanOlson3500");
  LocalGroupedManhattan out{replay(log, ReplayOptions()), 0.0};
  PoseGraph optimum = graphFromLog(log);
  BatchOptions batch;
  batch.skip_outliers = true;
  optimizeBatchGlobal(&optimum, batch);
  out.ate_vs_optimum = absoluteTrajectoryError(out.result.estimate, optimum.poses, 2);
  return out;
}

// Perceptual aliasing that a later revisit exposes (seed 2): near pose
// 3140 a group of false loop closures 25 poses back lands, bending the map
// costing less than rejecting them. The robot's true return to the same
// corridor a few poses on agrees with itself but not with the bent map, and
// landing it is refused as a trial. The refused group then gets the other
// hypothesis tried: the earlier landings in its window released, it lands,
// and the objective is lower. Measured: P = R = 1, ATE 0.0013 m from the
// outlier-free optimum (without the second hypothesis: P 0.995, R 0.989,
// 0.871 m; with the rejected group kept in the cost, at weights of up to
// 0.017 at mu = 1: 0.197 m).
TEST(IncrementalGncEndToEnd, ARefusedRevisitReleasesTheFalseGroupItContradicts) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const LocalGroupedManhattan run = replayLocalGroupedManhattan(2);
  EXPECT_DOUBLE_EQ(run.result.counts.precision(), 1.0);
  EXPECT_DOUBLE_EQ(run.result.counts.recall(), 1.0);
  EXPECT_LT(run.ate_vs_optimum, 0.05);
}

// The same, where the refused trial cannot show which landing the revisit
// contradicts (seed 3): four members of a false group 2520-2523 -> 2500-2503
// land (bending 20 poses of odometry costs less than rejecting four loop
// closures); the true revisit 2539-2540 -> 2504-2506 lands as a trial whose
// graduation keeps the false group and rejects the revisit, so no earlier
// landing ends beyond the inlier gate. Every earlier landing in the trial's
// window competes with the refused group, and the objective prefers the
// revisit. Measured: P = R = 1, 0.017 m from the outlier-free optimum
// (releasing only landings pushed beyond the gate: P 0.998, R 0.998, 2.18 m).
TEST(IncrementalGncEndToEnd, ARefusedRevisitCompetesWithEveryEarlierLandingInItsWindow) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const LocalGroupedManhattan run = replayLocalGroupedManhattan(3);
  EXPECT_DOUBLE_EQ(run.result.counts.precision(), 1.0);
  EXPECT_DOUBLE_EQ(run.result.counts.recall(), 1.0);
  EXPECT_LT(run.ate_vs_optimum, 0.1);
}

// M3500b (0.25 rad of rotation noise per edge) at 10 %, seed 2: the outlier
// 149-769 is rejected by the map twice (log-odds -17.7, -7.9) and explained
// at its third judgement at +0.39, on the map an earlier release left; it
// folds the map, and 1 900 poses later the revisit that contradicts the
// fold is refused (P 0.999, R 0.991, 14.6 m from the ground truth). Judged
// as the repeated test it is, the third judgement asks for odds above 3,
// and the cell ends where the outlier-free replay does (2.85 m).
// M3500b with random outliers against its outlier-free optimum, replayed
// with the default options; the ATE against Manhattan's ground truth.
struct HeavyNoiseManhattan {
  ReplayResult result;
  double ate_vs_truth = 0.0;
};
HeavyNoiseManhattan replayM3500b(double percent, int seed) {
  OutlierOptions outliers;
  outliers.percent = percent;
  outliers.seed = seed;
  const PoseGraph graph = injectOutliersAgainstOptimum(readG2o(dataset("M3500b.g2o")), "M3500b", outliers);
  HeavyNoiseManhattan run;
  run.result = replay(logFromGraph(graph, "M3500b"), ReplayOptions());
  run.ate_vs_truth =
      absoluteTrajectoryError(run.result.estimate, readG2o(dataset("manhattanOlson3500_gt.g2o")).poses, 2);
  return run;
}

TEST(IncrementalGncEndToEnd, AFalseLoopClosureDoesNotLandOnALaterWeakJudgement) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const HeavyNoiseManhattan run = replayM3500b(10.0, 2);
  EXPECT_DOUBLE_EQ(run.result.counts.precision(), 1.0);
  EXPECT_GE(run.result.counts.recall(), 0.99);
  EXPECT_LT(run.ate_vs_truth, 3.0);
}

// Intel with 30 % of its loop closures false in local groups (seed 2) begins
// with 64 poses of false groups only: the noise scale's first estimate, at
// 64 samples, is 116 in translation. Kept, it let five outliers in (0.54 m
// from the optimum); re-estimated as the samples double and followed down,
// it is 1 again by the end and the replay keeps no outlier.
TEST(IncrementalGncEndToEnd, ANoiseScaleMisledByAFirstStretchOfFalseGroupsComesBack) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  OutlierOptions outliers;
  outliers.percent = 30.0;
  outliers.seed = 2;
  outliers.mode = OutlierMode::kLocalGrouped;
  const PoseGraph graph = injectOutliersAgainstOptimum(readG2o(dataset("intel.g2o")), "intel", outliers);
  const ReplayResult result = replay(logFromGraph(graph, "intel"), ReplayOptions());
  EXPECT_EQ(result.noise_scale, Eigen::VectorXd::Ones(3));
  EXPECT_DOUBLE_EQ(result.counts.precision(), 1.0);
  EXPECT_DOUBLE_EQ(result.counts.recall(), 1.0);
}

// Entry by entry, the ring's closing loop closures arrive after a drift of
// metres: each is a confident outlier by its own covariance, but they come
// as a run that corroborates itself, so they land over the whole ring.
TEST(IncrementalGncEndToEnd, RingClosesWhenReplayedEntryByEntry) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const PoseGraph graph = withOutliers(readG2o(dataset("ring.g2o")), "ring", 10.0, 2);
  const ReplayResult result = replay(logFromGraph(graph, "ring"), ReplayOptions());
  EXPECT_EQ(result.counts.true_positive, 26);
  EXPECT_DOUBLE_EQ(result.counts.precision(), 1.0);
  EXPECT_DOUBLE_EQ(result.counts.recall(), 1.0);
}

// A drive around a block, back at the start after 800 one-metre steps, with
// odometry noise drawn at sigma 2 cm and 0.2 degrees per step; the
// odometry states `stated` times that sigma. A true loop closure measures
// the true relative pose at the same information; a false one claims that
// two places are the same.
struct BlockDrive {
  static constexpr int kSide = 200, kPoses = 4 * kSide;
  static constexpr double kSigmaXy = 0.02, kSigmaYaw = 0.2 * M_PI / 180.0;
  std::mt19937 random{7};
  std::normal_distribution<double> noise{0.0, 1.0};
  const Eigen::Matrix3d information =
      Eigen::Vector3d(1 / (kSigmaXy * kSigmaXy), 1 / (kSigmaXy * kSigmaXy), 1 / (kSigmaYaw * kSigmaYaw)).asDiagonal();
  double stated;
  Poses truth{Pose::fromSE2(0, 0, 0)};
  PoseGraph graph;
  IncrementalGnc engine{2, GncOptions()};

  explicit BlockDrive(double stated_noise) : stated(stated_noise) {
    graph.dimension = 2;
    engine.addFirstPose(truth[0], 1e8 * Eigen::Matrix3d::Identity());
    for (int i = 0; i < kPoses; ++i) step(i % kSide == kSide - 1 ? M_PI / 2 : 0.0);
  }
  // One metre on, turning by `turn` at its end.
  void step(double turn) {
    const int i = static_cast<int>(truth.size()) - 1;
    truth.push_back(truth[i] * Pose::fromSE2(1.0, 0.0, turn));
    Edge e = edge(i, i + 1, Pose::fromSE2(1.0 + kSigmaXy * noise(random), kSigmaXy * noise(random),
                                          turn + kSigmaYaw * noise(random)));
    e.information = information / (stated * stated);
    e.kind = EdgeKind::kOdometry;
    graph.edges.push_back(e);
    engine.addOdometry(e);
  }
  const LoopClosure& close(int from, int to) { return add(from, to, truth[from].inverse() * truth[to]); }
  const LoopClosure& claimSamePlace(int from, int to) { return add(from, to, Pose::fromSE2(0, 0, 0)); }
  PoseGraph optimum() const {
    PoseGraph g = graph;
    initializeFromOdometry(&g);
    optimizeBatch(&g);
    return g;
  }

 private:
  const LoopClosure& add(int from, int to, const Pose& z) {
    Edge e = edge(from, to, z);
    e.information = information;
    e.kind = EdgeKind::kLoopClosure;
    graph.edges.push_back(e);
    engine.addLoopClosure(e);
    engine.update();
    return engine.loopClosures().back();
  }
};

// The drift is metres, so the loop closure that closes the block is hundreds
// of sigma off by its own covariance, and it comes alone. The map explains
// it -- the odometry's uncertainty over 800 steps covers the drift far
// better than chance would -- so it is landed and the map closes onto the
// least-squares optimum.
TEST(IncrementalGncEndToEnd, ALoneLoopClosureAfterALongDriftClosesTheMap) {
  BlockDrive drive(1.0);
  const double drift = drive.engine.pose(BlockDrive::kPoses).translation.norm();
  EXPECT_GT(drift, 2.0);
  const LoopClosure& loop = drive.close(BlockDrive::kPoses, 0);
  EXPECT_TRUE(loop.inlier);
  EXPECT_FALSE(loop.uncorroborated);
  EXPECT_LT(absoluteTrajectoryError(drive.engine.poses(), drive.optimum().poses, 2), 0.01 * drift);
}

// A loop closure of the drive (from, to) measured as `z`, with the drive's
// loop-closure information.
Edge driveLoop(const BlockDrive& drive, int from, int to, const Pose& z) {
  Edge e = edge(from, to, z);
  e.information = drive.information;
  e.kind = EdgeKind::kLoopClosure;
  return e;
}

// The loop closure that closes the block, measured as the truth has it.
Edge closingLoop(const BlockDrive& drive) {
  return driveLoop(drive, BlockDrive::kPoses, 0, drive.truth[BlockDrive::kPoses].inverse() * drive.truth[0]);
}

// Adds `loops(drive)` to two identical drives and updates both, one with the
// anytime report: the report comes once, with the estimate before the
// update, and the update ends as it ends without it, every loop closure
// kept and the block closed (the whole cycle free, the last pose moved).
void expectTheEstimateBeforeTheLanding(const std::function<std::vector<Edge>(const BlockDrive&)>& loops) {
  BlockDrive reported(1.0), silent(1.0);
  const Poses before = reported.engine.poses();
  for (const Edge& e : loops(reported)) {
    reported.engine.addLoopClosure(e);
    silent.engine.addLoopClosure(e);
  }
  int calls = 0;
  Poses first;
  const UpdateStats stats = reported.engine.update([&] {
    ++calls;
    first = reported.engine.poses();
  });
  silent.engine.update();
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(stats.first_variable, 0);
  ASSERT_EQ(first.size(), before.size());
  for (size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(first[i].translation, before[i].translation) << "pose " << i;
    EXPECT_EQ(reported.engine.pose(i).translation, silent.engine.pose(i).translation) << "pose " << i;
  }
  for (const LoopClosure& loop : reported.engine.loopClosures()) EXPECT_TRUE(loop.inlier);
  const int last = BlockDrive::kPoses;
  EXPECT_GT((reported.engine.pose(last).translation - first[last].translation).norm(), 1.0);
}

// Anytime: landing the loop closure frees the whole block and iterates to
// convergence, which on a large map takes long. The landing is all the
// update moves, so the estimate before its trial comes first (the odometry's,
// as it stays should the trial be refused).
TEST(IncrementalGncEndToEnd, ALandingReportsTheEstimateBeforeItsTrialFirst) {
  expectTheEstimateBeforeTheLanding([](const BlockDrive& drive) { return std::vector<Edge>{closingLoop(drive)}; });
}

// Far work in an update that also brings a loop closure near the estimate:
// the near one agrees with the estimate of the moment within its own noise,
// so that estimate is still a fair first one, and it comes before the
// prediction and the landing (the slow part) rather than after them.
TEST(IncrementalGncEndToEnd, ALandingWithANearLoopClosureReportsTheEstimateBeforeItsWork) {
  expectTheEstimateBeforeTheLanding([](const BlockDrive& drive) {
    // Measured where the estimate has it: near by any covariance.
    const int last = BlockDrive::kPoses;
    const Pose near = drive.engine.pose(last).inverse() * drive.engine.pose(last - 3);
    return std::vector<Edge>{driveLoop(drive, last, last - 3, near), closingLoop(drive)};
  });
}

// The map's prediction factorises the whole block, the slow part of judging
// a far loop closure: it comes after the first estimate, which here is also
// the last (the map cannot tell, so the loop closure waits, and nothing
// moves). No path rules it out, so the report can only have come from the
// hook before the prediction.
TEST(IncrementalGncEndToEnd, AFarJudgementReportsTheEstimateBeforeThePrediction) {
  BlockDrive drive(200.0);
  const Poses before = drive.engine.poses();
  Edge closing = edge(BlockDrive::kPoses, 0, drive.truth[BlockDrive::kPoses].inverse() * drive.truth[0]);
  closing.information = drive.information;
  closing.kind = EdgeKind::kLoopClosure;
  drive.engine.addLoopClosure(closing);
  int calls = 0;
  drive.engine.update([&] { ++calls; });
  EXPECT_EQ(calls, 1);
  EXPECT_FALSE(drive.engine.loopClosures()[0].inlier);
  EXPECT_EQ(drive.engine.loopClosures()[0].map_judgements, 1);
  for (size_t i = 0; i < before.size(); ++i) EXPECT_EQ(drive.engine.pose(i).translation, before[i].translation);
}

// A false loop closure: back at the start, the front-end matches the far
// corner of the block (283 m away). The odometry knows the block far better
// than that: rejected without a solve.
TEST(IncrementalGncEndToEnd, ALoneFalseLoopClosureIsRejectedByTheMap) {
  BlockDrive drive(1.0);
  const Pose before = drive.engine.pose(BlockDrive::kPoses);
  const LoopClosure& loop = drive.claimSamePlace(BlockDrive::kPoses, 2 * BlockDrive::kSide);
  EXPECT_FALSE(loop.inlier);
  EXPECT_TRUE(loop.uncorroborated);
  EXPECT_EQ(drive.engine.pose(BlockDrive::kPoses).translation, before.translation);
}

// Odometry that states 200 times its noise (sigma 4 m and 40 degrees per
// step): after 800 steps the map could be anywhere, so it explains the true
// loop closure no better than chance. Alone, it is held back; the next one
// of the revisit, which agrees with it, lands both.
TEST(IncrementalGncEndToEnd, AnUncertainMapWaitsForASecondLoopClosure) {
  BlockDrive drive(200.0);
  const Pose before = drive.engine.pose(BlockDrive::kPoses);
  const LoopClosure& first = drive.close(BlockDrive::kPoses, 0);
  EXPECT_FALSE(first.inlier);
  EXPECT_TRUE(first.uncorroborated);
  EXPECT_EQ(drive.engine.pose(BlockDrive::kPoses).translation, before.translation);

  drive.step(0.0);
  drive.close(BlockDrive::kPoses + 1, 1);
  EXPECT_TRUE(drive.engine.loopClosures()[0].inlier);
  EXPECT_TRUE(drive.engine.loopClosures()[1].inlier);
}

// The revisit of KITTI 02 (SE-Sync's data): after a long drift the map
// cannot explain its first loop closure alone, and a pair of them costs the
// odometry more than rejecting them saves, so pair after pair is refused;
// three together lower the objective. Here the block again, its odometry
// stating 0.37 times its noise (the drift is larger than the map believes),
// and a loop closure every third pose of the revisit: each arriving one has
// only its predecessor within the support radius, so the run is judged
// through the chain of neighbours that corroborate each other. Measured:
// all four land with the fourth (judged pair by pair: none until the
// seventh).
TEST(IncrementalGncEndToEnd, ARevisitIsJudgedAsOneRun) {
  BlockDrive drive(0.37);
  ASSERT_EQ(GncOptions().rejection.support_radius, 5);
  for (int j = 0; j < 4; ++j) {
    if (j > 0)
      for (int s = 0; s < 3; ++s) drive.step(0.0);
    drive.close(BlockDrive::kPoses + 3 * j, 3 * j);
  }
  for (const LoopClosure& loop : drive.engine.loopClosures()) EXPECT_TRUE(loop.inlier) << loop.edge.from;
}

// A straight corridor whose odometry states 2.5 mm per step (and next to no
// heading noise), revisited by two neighbouring loop closures that both say
// the corridor lies 7 sigma (7 cm) to the side of where the odometry puts
// it, 50 poses back, where the odometry's lateral variance is 3.1 times the
// loop closure's. Alone, the first is ruled out by the map (landing it would
// cost about 49 / (2 (1 + 3.1)) = 5.9, more than rejecting it does: rho(7) =
// 3.8 at mu = 1) and stays at r = 7, inside the inlier gate of the reference
// convention (q(0.95) = 7.81 on r) though rejected. The second agrees with
// it, and the two together pay (49 / (1 + 6.25) = 6.8 against 7.6). A
// rejected neighbour is one the engine rejected -- ruled out by the map or
// refused by the objective -- whatever band of the classification its
// residual falls in, so the two land as one run.
TEST(IncrementalGncEndToEnd, ARefusedLoopClosureInsideTheInlierGateCorroboratesItsNeighbour) {
  const double sigma_step = 0.0025, sigma_heading = 1e-5, sigma_loop = 0.01;
  IncrementalGnc engine(2, GncOptions());
  engine.addFirstPose(Pose::fromSE2(0, 0, 0), 1e8 * Eigen::Matrix3d::Identity());
  const auto step = [&](int i) {
    Edge e = edge(i, i + 1, Pose::fromSE2(1.0, 0.0, 0.0));
    e.information = Eigen::Vector3d(1 / (sigma_step * sigma_step), 1 / (sigma_step * sigma_step),
                                    1 / (sigma_heading * sigma_heading))
                        .asDiagonal();
    e.kind = EdgeKind::kOdometry;
    engine.addOdometry(e);
  };
  const auto close = [&](int newer) -> const LoopClosure& {
    Edge e = edge(newer, newer - 50, Pose::fromSE2(-50.0, 7.0 * sigma_loop, 0.0),
                  1 / (sigma_loop * sigma_loop));
    e.kind = EdgeKind::kLoopClosure;
    engine.addLoopClosure(e);
    engine.update();
    return engine.loopClosures().back();
  };
  for (int i = 0; i < 60; ++i) step(i);
  const LoopClosure& first = close(60);
  EXPECT_TRUE(first.uncorroborated);
  EXPECT_LT(first.weight, 0.1);
  EXPECT_NEAR(first.distance, 7.0, 1e-3);
  EXPECT_TRUE(first.inlier);  // the classification's band: r < q(0.95)

  step(60);
  close(61);
  for (const LoopClosure& loop : engine.loopClosures()) {
    EXPECT_GT(loop.weight, 0.9) << loop.edge.from;
    EXPECT_LT(loop.distance, 2.0) << loop.edge.from;
    EXPECT_FALSE(loop.undone) << loop.edge.from;
  }
}

// A map too uncertain for a loop closure is tightened by a later one: the
// block again, its odometry stating 15 times its noise, so the 800-pose
// loop closure back to the start (A) is held back. The drive goes on east
// along the bottom and north through the middle of the block, and closes a
// 600-pose cycle there (B), which the map explains. Once B has landed, the
// map between A's endpoints is tighter: A is judged again and lands too.
TEST(IncrementalGncEndToEnd, ALoopClosureTheMapCouldNotTellIsJudgedAgainWhenItTightens) {
  BlockDrive drive(15.0);
  const IncrementalGnc& engine = drive.engine;
  drive.close(BlockDrive::kPoses, 0);
  EXPECT_TRUE(engine.loopClosures()[0].uncorroborated);
  EXPECT_FALSE(engine.loopClosures()[0].inlier);
  for (int i = 0; i < 100; ++i) drive.step(i == 99 ? M_PI / 2 : 0.0);
  for (int i = 0; i < 200; ++i) drive.step(0.0);
  ASSERT_LT((drive.truth[1100].translation - drive.truth[500].translation).norm(), 1e-9);
  drive.close(1100, 500);
  EXPECT_TRUE(engine.loopClosures()[1].inlier);
  EXPECT_TRUE(engine.loopClosures()[0].inlier);
  EXPECT_FALSE(engine.loopClosures()[0].uncorroborated);
  EXPECT_LT(absoluteTrajectoryError(engine.poses(), drive.optimum().poses, 2), 0.05);
}

// Adds `edges` to `engine` in order; with `update`, updates after each loop
// closure, as BlockDrive does.
void feed(IncrementalGnc* engine, const std::vector<Edge>& edges, bool update) {
  for (const Edge& e : edges) {
    if (e.kind == EdgeKind::kOdometry) {
      engine->addOdometry(e);
    } else {
      engine->addLoopClosure(e);
      if (update) engine->update();
    }
  }
}

// Whether the estimate changed at all, to the bit (an ATE after alignment
// is not exactly zero between identical estimates: the alignment rounds).
bool moved(const Poses& before, const Poses& after) {
  if (before.size() != after.size()) return true;
  for (size_t i = 0; i < before.size(); ++i)
    if (before[i].translation != after[i].translation || !(before[i].rotation.coeffs() == after[i].rotation.coeffs()))
      return true;
  return false;
}

// The generated 400-pose grid world (all loop closures true), fed to
// `engine` with an update after each loop closure.
void feedGridWorld(IncrementalGnc* engine) {
  const PoseGraph graph = readG2o(std::string(AGNC_PGO_TEST_WORLD_DIR) + "/grid2d_400_seed1.g2o");
  engine->addFirstPose(graph.poses[0], 1e8 * Eigen::Matrix3d::Identity());
  feed(engine, graph.edges, /*update=*/true);
}

// An update refines the whole graph only once its windows' net displacement
// amounts to convergence_step per pose, so the estimate after the last
// update is near the minimum of the engine's objective, not at it. Idle
// time (refineIdle()) brings it there -- optimize() finds nothing left to
// move -- then has nothing to do until an update solves again; odometry
// alone or a loop closure still waiting for update() gives it none.
TEST(IncrementalGnc, IdleRefinementConvergesWhatTheUpdatesLeft) {
  IncrementalGnc engine(2, GncOptions());
  feedGridWorld(&engine);
  const Poses after_updates = engine.poses();
  // The calls that moved the estimate: the idle refinement's iterations
  // (the fold check after them leaves it, see below).
  int iterations = 0;
  for (Poses last = engine.poses(); engine.refineIdle();) {
    if (moved(last, engine.poses())) ++iterations;
    last = engine.poses();
  }
  const Poses after_idle = engine.poses();
  engine.optimize(20);
  const double left_by_updates = absoluteTrajectoryError(after_updates, engine.poses(), 2);
  const double left_by_idle = absoluteTrajectoryError(after_idle, engine.poses(), 2);
  EXPECT_GE(iterations, 1);
  EXPECT_LE(iterations, 5);
  EXPECT_GT(left_by_updates, 1e-3);
  EXPECT_LT(left_by_idle, 0.05 * left_by_updates);
  for (const LoopClosure& loop : engine.loopClosures()) EXPECT_TRUE(loop.inlier);
  engine.restore(engine.poses(), engine.loopStates());
  EXPECT_FALSE(engine.hasIdleWork());  // a restored estimate stays as saved

  const int n = engine.numPoses();
  engine.addOdometry(edge(n - 1, n, Pose::fromSE2(1, 0, 0)));
  engine.update();
  EXPECT_FALSE(engine.refineIdle());
  engine.addLoopClosure(edge(n, n - 2, Pose::fromSE2(-2, 0, 0)));
  EXPECT_FALSE(engine.refineIdle());  // waits for update()
  engine.update();
  EXPECT_TRUE(engine.refineIdle());
}

// After the idle refinement, refineIdle() checks the map for a fold (a
// second estimate from a global start, incremental_gnc.h): between its
// calls the engine shows its own estimate, and only the verdict may change
// it. On the generated grid the second estimate ends where the engine's is
// (every loop closure true and kept), so the estimate stays bit for bit.
TEST(IncrementalGnc, TheFoldCheckShowsTheEnginesOwnEstimateUntilItsVerdict) {
  IncrementalGnc engine(2, GncOptions());
  feedGridWorld(&engine);
  std::vector<int> changes;  // per call: did the estimate change
  for (Poses last = engine.poses(); engine.refineIdle();) {
    changes.push_back(moved(last, engine.poses()));
    last = engine.poses();
  }
  // The idle refinement's iterations first, then the check: three stages of
  // at least one iteration each after its start.
  const auto first_still = std::find(changes.begin(), changes.end(), 0);
  ASSERT_NE(first_still, changes.end());
  EXPECT_GE(changes.end() - first_still, 4);
  EXPECT_TRUE(std::all_of(first_still, changes.end() - 1, [](int m) { return m == 0; }));
  EXPECT_FALSE(engine.hasIdleWork());
  for (const LoopClosure& loop : engine.loopClosures()) EXPECT_TRUE(loop.inlier);
}

// A second odometry chain (a gap in the odometry) that one lone loop
// closure attaches: the check's start keeps that attachment (without it the
// chain has no place in a global start, and no check would run), and tests
// the others as on one chain. The estimate stays bit for bit.
TEST(IncrementalGnc, TheFoldCheckKeepsTheLoneAttachmentOfASecondChain) {
  IncrementalGnc engine(2, GncOptions());
  feedGridWorld(&engine);
  const int start = engine.numPoses();
  const Pose offset = Pose::fromSE2(1, 0, 0);
  engine.addPoseWithPrior(engine.pose(50) * offset, 1e-6 * Eigen::Matrix3d::Identity());
  for (int i = 0; i < 3; ++i) engine.addOdometry(edge(start + i, start + i + 1, Pose::fromSE2(1, 0, 0)));
  const int attachment = engine.addLoopClosure(edge(start, 50, offset.inverse()));
  engine.update();
  std::vector<int> changes;
  for (Poses last = engine.poses(); engine.refineIdle();) {
    changes.push_back(moved(last, engine.poses()));
    last = engine.poses();
  }
  const auto first_still = std::find(changes.begin(), changes.end(), 0);
  ASSERT_NE(first_still, changes.end());
  EXPECT_GE(changes.end() - first_still, 4);  // the check's start and its three stages
  EXPECT_TRUE(std::all_of(first_still, changes.end() - 1, [](int m) { return m == 0; }));
  for (const LoopClosure& loop : engine.loopClosures()) EXPECT_TRUE(loop.inlier);
  EXPECT_TRUE(engine.loopClosures()[attachment].inlier);
}

// Anything that changes the graph discards an unfinished check: a keyframe
// added during one is composed from the engine's own estimate, and the
// checks start again in the next idle time, the engine's estimate shown
// until the last verdict (the full-weight check's, which on the grid holds
// some kept loop closures at full weight that Geman-McClure left beyond
// their gate: the only call that moves the estimate).
TEST(IncrementalGnc, ANewKeyframeDiscardsAnUnfinishedFoldCheck) {
  IncrementalGnc engine(2, GncOptions());
  feedGridWorld(&engine);
  // Until the estimate stops moving (the idle refinement has converged),
  // then two calls of the check.
  Poses last = engine.poses();
  for (int still = 0; still < 2;) {
    ASSERT_TRUE(engine.refineIdle());
    still = moved(last, engine.poses()) ? 0 : still + 1;
    last = engine.poses();
  }
  const int n = engine.numPoses();
  const Pose step = Pose::fromSE2(1, 0, 0);
  engine.addOdometry(edge(n - 1, n, step));
  const Pose expected = last[n - 1] * step;
  EXPECT_LT((engine.pose(n).translation - expected.translation).norm(), 1e-12);
  EXPECT_TRUE(engine.hasIdleWork());  // the check is still due
  std::vector<int> changes;  // per call: did the estimate change
  for (Poses before = engine.poses(); engine.refineIdle(); before = engine.poses())
    changes.push_back(moved(before, engine.poses()));
  EXPECT_GE(changes.size(), 4u);
  EXPECT_TRUE(std::all_of(changes.begin(), changes.end() - 1, [](int m) { return m == 0; }));
}

// M3500b (0.25 rad of rotation noise per edge) at 30 %, seed 1: the replay
// keeps no outlier and all but two true loop closures (415-1909 and
// 414-1911), yet ends 12.7 m from the ground truth: a fold, a worse minimum
// of the objective than the one next to the truth (measured: 4 752 against
// 4 740 from the outlier-free optimum). The fold check's second estimate --
// least squares over the corroborated loop closures from a global start,
// then the robust objective -- ends lower and is adopted: within 5 % of
// least squares on the outlier-free graph (2.66 m from the ground truth),
// every loop closure right.
TEST(IncrementalGncEndToEnd, TheFoldCheckUnfoldsAHeavyNoiseMap) {
  AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS();
  const HeavyNoiseManhattan run = replayM3500b(30.0, 1);
  EXPECT_DOUBLE_EQ(run.result.counts.precision(), 1.0);
  EXPECT_DOUBLE_EQ(run.result.counts.recall(), 1.0);
  EXPECT_LT(run.ate_vs_truth, 1.05 * 2.66);
}

// A saved state -- the estimate and loopStates() -- restored into an engine
// rebuilt from the same edges goes on as the saved engine does: the loop
// closure rejected as unexplained (uncorroborated) is judged again once a
// later one tightens the map (the drive of the test above), in the rebuilt
// engine too, and both end at the same estimate.
TEST(IncrementalGncEndToEnd, ARestoredEngineGoesOnAsTheSavedOne) {
  BlockDrive drive(15.0);
  drive.close(BlockDrive::kPoses, 0);
  ASSERT_TRUE(drive.engine.loopClosures()[0].uncorroborated);
  IncrementalGnc restored(2, GncOptions());
  restored.addFirstPose(drive.truth[0], 1e8 * Eigen::Matrix3d::Identity());
  feed(&restored, drive.graph.edges, /*update=*/false);
  restored.restore(drive.engine.poses(), drive.engine.loopStates());
  EXPECT_TRUE(restored.loopClosures()[0].uncorroborated);
  EXPECT_GE(drive.engine.loopClosures()[0].map_judgements, 1);
  EXPECT_EQ(restored.loopClosures()[0].map_judgements, drive.engine.loopClosures()[0].map_judgements);
  EXPECT_FALSE(restored.loopClosures()[0].inlier);

  const size_t saved_edges = drive.graph.edges.size();
  for (int i = 0; i < 100; ++i) drive.step(i == 99 ? M_PI / 2 : 0.0);
  for (int i = 0; i < 200; ++i) drive.step(0.0);
  drive.close(1100, 500);
  feed(&restored, std::vector<Edge>(drive.graph.edges.begin() + saved_edges, drive.graph.edges.end()), /*update=*/true);
  ASSERT_TRUE(drive.engine.loopClosures()[0].inlier);
  for (int k = 0; k < 2; ++k) {
    EXPECT_TRUE(restored.loopClosures()[k].inlier) << k;
    EXPECT_FALSE(restored.loopClosures()[k].uncorroborated) << k;
  }
  EXPECT_LT(absoluteTrajectoryError(restored.poses(), drive.engine.poses(), 2), 1e-6);
}

// A false loop closure the map cannot rule out: back at the start, the
// front-end claims that the end of the block is the place 30 m along its
// first side. The odometry's uncertainty over 800 steps covers 30 m, so the
// claim is landed as a trial; bending the block onto it costs more than
// rejecting it, so the trial is undone. That verdict stands when a later
// true loop closure tightens the map: only a corroborating loop closure
// would land the claim again, so closing the later cycle costs what it costs
// in the same drive without the claim.
TEST(IncrementalGncEndToEnd, AnUndoneTrialIsNotJudgedAgainWhenTheMapTightens) {
  long steps_to_close[2];
  for (bool claim : {false, true}) {
    BlockDrive drive(1.0);
    const IncrementalGnc& engine = drive.engine;
    if (claim) {
      const LoopClosure& alias = drive.claimSamePlace(BlockDrive::kPoses, 30);
      EXPECT_TRUE(alias.undone);
      EXPECT_FALSE(alias.inlier);
    }
    for (int i = 0; i < 100; ++i) drive.step(i == 99 ? M_PI / 2 : 0.0);
    for (int i = 0; i < 200; ++i) drive.step(0.0);
    const long before = engine.totalGncSteps();
    EXPECT_TRUE(drive.close(1100, 500).inlier);
    steps_to_close[claim] = engine.totalGncSteps() - before;
    if (claim) {
      EXPECT_TRUE(engine.loopClosures()[0].undone);
      EXPECT_FALSE(engine.loopClosures()[0].inlier);
    }
  }
  EXPECT_EQ(steps_to_close[true], steps_to_close[false]);
}

// Two sessions: the second starts 30 m and 1 rad away from where the first
// ended, with no odometry between them (a robot restarted). Its loop
// closures to the first session attach it; the result is the least-squares
// optimum of the joined graph.
TEST(IncrementalGncEndToEnd, SecondSessionIsAttachedByItsLoopClosures) {
  PoseGraph graph;
  graph.dimension = 2;
  const int session = 60;
  for (int i = 0; i < 2 * session; ++i) {
    const int k = i % session;
    const Pose truth = Pose::fromSE2(k, 0.0, 0.0);
    graph.poses.push_back(i < session ? truth : Pose::fromSE2(30.0, 20.0, 1.0) * truth);
    if (k > 0) {
      Edge e = edge(i - 1, i, Pose::fromSE2(1.0, 0.0, 0.0));
      e.kind = EdgeKind::kOdometry;
      graph.edges.push_back(e);
    }
  }
  for (int k = 10; k < session; k += 5) {  // the second drive revisits the first
    Edge loop = edge(session + k, k, Pose::fromSE2(0.0, 0.0, 0.0));
    loop.kind = EdgeKind::kLoopClosure;
    graph.edges.push_back(loop);
  }
  const IncrementalLog log = logFromGraph(graph, "two sessions");
  const ReplayResult result = replay(log, ReplayOptions());
  EXPECT_EQ(result.counts.true_positive, 10);
  EXPECT_EQ(result.counts.false_negative, 0);
  for (int k = 0; k < session; ++k)
    EXPECT_LT((result.estimate[session + k].translation - result.estimate[k].translation).norm(), 1e-3) << k;
}

// The block driven again along its first side, its second lap closed pose
// by pose (kPoses + k -> k, k = 0..10) as the truth has it, but for the
// sixth loop closure, measured `offset` loop-closure sigmas off along the
// track; then idle time until the engine has no work left. Returns the
// calls of refineIdle() that changed the estimate, in order.
std::vector<int> closeTheSecondLap(BlockDrive* drive, double offset) {
  for (int k = 0; k < 12; ++k) drive->step(0.0);
  const int n = BlockDrive::kPoses;
  for (int k = 0; k <= 10; ++k) {
    Pose z = drive->truth[n + k].inverse() * drive->truth[k];
    if (k == 5) z = z * Pose::fromSE2(offset * BlockDrive::kSigmaXy, 0.0, 0.0);
    const Edge e = driveLoop(*drive, n + k, k, z);
    drive->graph.edges.push_back(e);
    drive->engine.addLoopClosure(e);
    drive->engine.update();
  }
  std::vector<int> changes;
  for (Poses last = drive->engine.poses(); drive->engine.refineIdle();) {
    changes.push_back(moved(last, drive->engine.poses()));
    last = drive->engine.poses();
  }
  return changes;
}

// At the least-squares optimum the offset loop closure sits at r = 2.06,
// within its chi-square gate (r^2 < 7.81), but Geman-McClure's weight at
// 2 sigma (0.48) lets the odometry pull it out to r = 4.1, where its weight
// is 0.12: the updates left it there, 1.1 mm from the optimum. The idle
// full-weight check tries it at full weight, finds it within the gate at
// convergence and keeps it there: the estimate is least squares over the
// kept loop closures. Between its calls the engine shows its own estimate;
// only the verdict, the last call, changes it.
TEST(IncrementalGncEndToEnd, TheFullWeightCheckHoldsAKeptLoopClosureWhereLeastSquaresDoes) {
  BlockDrive drive(1.0);
  const std::vector<int> changes = closeTheSecondLap(&drive, 5.0);
  const double q95 = ChiSquareThresholds::forDof(3).q95;
  for (const LoopClosure& loop : drive.engine.loopClosures()) {
    EXPECT_TRUE(loop.inlier);
    EXPECT_TRUE(loop.full_weight);
    EXPECT_LT(loop.distance * loop.distance, q95);
  }
  EXPECT_LT(absoluteTrajectoryError(drive.engine.poses(), drive.optimum().poses, 2), 2e-4);
  const auto first_still = std::find(changes.begin(), changes.end(), 0);
  ASSERT_NE(first_still, changes.end());
  EXPECT_TRUE(std::all_of(first_still, changes.end() - 1, [](int m) { return m == 0; }));
  EXPECT_EQ(changes.back(), 1);
  EXPECT_FALSE(drive.engine.hasIdleWork());
}

// Seven sigmas off, least squares puts the loop closure at r = 2.9, beyond
// its gate: the check returns it to its kernel weight (kept, r = 4.9) and
// every other loop closure stays at full weight.
TEST(IncrementalGncEndToEnd, TheFullWeightCheckLeavesBeyondTheGateWhatLeastSquaresLeavesThere) {
  BlockDrive drive(1.0);
  closeTheSecondLap(&drive, 7.0);
  const double q95 = ChiSquareThresholds::forDof(3).q95;
  const std::vector<LoopClosure>& loops = drive.engine.loopClosures();
  for (size_t k = 0; k < loops.size(); ++k) {
    EXPECT_TRUE(loops[k].inlier) << k;
    EXPECT_EQ(loops[k].full_weight, k != 5) << k;
  }
  EXPECT_GT(loops[5].distance * loops[5].distance, q95);
  EXPECT_LT(loops[5].weight, 0.2);
}
