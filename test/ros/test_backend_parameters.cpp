// The runtime parameters (dynamic_reconfigure) without a master: the
// generated configs and the parameter lists agree, a request is validated as
// at start-up, changes are described, and a GNC change rebuilds the engine
// from its exact state (estimate, graduation, pending loop closures, totals).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "agnc_pgo/BackendConfig.h"
#include "agnc_pgo/GncConfig.h"
#include "agnc_pgo/ros/backend_graph.h"
#include "agnc_pgo/ros/backend_parameters.h"

namespace agnc_pgo {
namespace ros_backend {
namespace {

std::vector<std::string> namesOf(const dynamic_reconfigure::Config& msg) {
  std::vector<std::string> names;
  for (const auto& e : msg.bools) names.push_back(e.name);
  for (const auto& e : msg.ints) names.push_back(e.name);
  for (const auto& e : msg.doubles) names.push_back(e.name);
  for (const auto& e : msg.strs) names.push_back(e.name);
  std::sort(names.begin(), names.end());
  return names;
}

template <class Config>
dynamic_reconfigure::Config defaultMessage() {
  dynamic_reconfigure::Config msg;
  Config::__getDefault__().__toMessage__(msg);
  return msg;
}

template <class Config>
dynamic_reconfigure::Config messageOf(const BackendParameters& p, const std::string& ns) {
  dynamic_reconfigure::Config msg;
  toConfig<Config>(p, ns).__toMessage__(msg);
  return msg;
}

void setDouble(dynamic_reconfigure::Config* msg, const std::string& name, double value) {
  for (auto& e : msg->doubles)
    if (e.name == name) e.value = value;
}

void setString(dynamic_reconfigure::Config* msg, const std::string& name, const std::string& value) {
  for (auto& e : msg->strs)
    if (e.name == name) e.value = value;
}

// `p` with gnc options edited through a GncConfig, as a request would do
// (the tests name no GncOptions field: the mapping lives in one place).
BackendParameters withGnc(const BackendParameters& p, const std::function<void(agnc_pgo::GncConfig&)>& edit) {
  agnc_pgo::GncConfig config = toConfig<agnc_pgo::GncConfig>(p, kGncNamespace);
  edit(config);
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  return readRuntimeParameters(p, kGncNamespace, msg);
}

// An engine's options as the ~gnc server would show them.
agnc_pgo::GncConfig gncOf(const core::GncOptions& options) {
  BackendParameters p;
  p.gnc = options;
  return toConfig<agnc_pgo::GncConfig>(p, kGncNamespace);
}

// Expects readRuntimeParameters to refuse `msg` with a message naming `parameter`.
void expectRefused(const BackendParameters& current, const std::string& ns, const dynamic_reconfigure::Config& msg,
                   const std::string& parameter) {
  try {
    readRuntimeParameters(current, ns, msg);
    ADD_FAILURE() << "accepted; expected a refusal naming " << parameter;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(parameter), std::string::npos) << e.what();
  }
}

TEST(RuntimeParameters, GeneratedConfigsAndParameterListsAgree) {
  for (const std::string& ns : {std::string(), std::string(kGncNamespace)}) {
    std::vector<std::string> listed = runtimeParameterNames(ns);
    std::sort(listed.begin(), listed.end());
    const dynamic_reconfigure::Config msg =
        ns.empty() ? defaultMessage<agnc_pgo::BackendConfig>() : defaultMessage<agnc_pgo::GncConfig>();
    EXPECT_EQ(namesOf(msg), listed) << "server ~" << ns;
  }
  EXPECT_EQ(runtimeParameterNames("").size(), 11u);
  EXPECT_EQ(runtimeParameterNames(kGncNamespace).size(), 20u);
  EXPECT_THROW(runtimeParameterNames("keyframes"), std::logic_error);
  // An entry no parameter maps is an error, not silently ignored.
  dynamic_reconfigure::Config extra = defaultMessage<agnc_pgo::BackendConfig>();
  dynamic_reconfigure::DoubleParameter unknown;
  unknown.name = "keyframe_translation";
  extra.doubles.push_back(unknown);
  EXPECT_THROW(writeRuntimeParameters(BackendParameters(), "", &extra), std::logic_error);
}

TEST(RuntimeParameters, CfgDefaultsAreTheParameterDefaults) {
  // The servers start from the yaml, but rqt's "defaults" should not lie.
  const BackendParameters defaults;
  EXPECT_EQ(describeChanges(defaults, readRuntimeParameters(defaults, "", defaultMessage<agnc_pgo::BackendConfig>())),
            "");
  EXPECT_EQ(describeChanges(defaults, readRuntimeParameters(defaults, kGncNamespace,
                                                            defaultMessage<agnc_pgo::GncConfig>())),
            "");
}

TEST(RuntimeParameters, ConfigCarriesTheValuesInForceNotTheCfgDefaults) {
  BackendParameters p;
  p.tf_rate = 25.0;
  p.paused = true;
  p.optimize_iterations = 7;
  p = withGnc(p, [](agnc_pgo::GncConfig& c) {
    c.schedule = "risam";
    c.distance = "squared";
    c.max_gnc_steps = 40;
    c.local_window = false;
  });
  EXPECT_EQ(describeChanges(BackendParameters(), p),
            "~paused false -> true, ~tf_rate 20 -> 25, ~optimize_iterations 20 -> 7, ~gnc/schedule agnc -> risam, "
            "~gnc/distance reference -> squared, ~gnc/local_window true -> false, ~gnc/max_gnc_steps 30 -> 40");
  const agnc_pgo::BackendConfig backend = toConfig<agnc_pgo::BackendConfig>(p, "");
  EXPECT_EQ(backend.tf_rate, 25.0);
  EXPECT_TRUE(backend.paused);
  EXPECT_EQ(backend.optimize_iterations, 7);
  const agnc_pgo::GncConfig gnc = toConfig<agnc_pgo::GncConfig>(p, kGncNamespace);
  EXPECT_EQ(gnc.schedule, "risam");
  EXPECT_EQ(gnc.distance, "squared");
  EXPECT_EQ(gnc.max_gnc_steps, 40);
  EXPECT_FALSE(gnc.local_window);
  // ... and reading them back onto the defaults gives p again.
  BackendParameters back = readRuntimeParameters(BackendParameters(), "", messageOf<agnc_pgo::BackendConfig>(p, ""));
  back = readRuntimeParameters(back, kGncNamespace, messageOf<agnc_pgo::GncConfig>(p, kGncNamespace));
  EXPECT_EQ(describeChanges(p, back), "");
}

TEST(RuntimeParameters, InvalidRequestsAreRefusedNamingTheParameter) {
  const BackendParameters current;
  dynamic_reconfigure::Config msg = messageOf<agnc_pgo::BackendConfig>(current, "");
  setDouble(&msg, "tf_rate", 0.0);
  expectRefused(current, "", msg, "~tf_rate");
  msg = messageOf<agnc_pgo::BackendConfig>(current, "");
  setDouble(&msg, "stamp_tolerance", -1.0);
  expectRefused(current, "", msg, "~stamp_tolerance");
  msg = messageOf<agnc_pgo::BackendConfig>(current, "");
  setDouble(&msg, "max_position", 1e10);  // beyond the file readers' bound
  expectRefused(current, "", msg, "~max_position");

  dynamic_reconfigure::Config gnc = messageOf<agnc_pgo::GncConfig>(current, kGncNamespace);
  setString(&gnc, "schedule", "bogus");
  expectRefused(current, kGncNamespace, gnc, "~gnc/schedule");
  gnc = messageOf<agnc_pgo::GncConfig>(current, kGncNamespace);
  setDouble(&gnc, "trust_region_radius", 5000.0);  // above max_trust_region_radius: core::validate
  expectRefused(current, kGncNamespace, gnc, "~gnc/max_trust_region_radius");
  gnc = messageOf<agnc_pgo::GncConfig>(current, kGncNamespace);
  setDouble(&gnc, "fixed_alpha", 1.5);
  expectRefused(current, kGncNamespace, gnc, "~gnc/fixed_alpha");

  // A valid request is taken.
  msg = messageOf<agnc_pgo::BackendConfig>(current, "");
  setDouble(&msg, "tf_rate", 4.0);
  EXPECT_EQ(readRuntimeParameters(current, "", msg).tf_rate, 4.0);
}

TEST(RuntimeParameters, ChangesAreDescribedAndOnlyRuntimeOnesCount) {
  const BackendParameters before;
  BackendParameters after = before;
  EXPECT_EQ(describeChanges(before, after), "");
  after.tf_rate = 5.0;
  after = withGnc(after, [](agnc_pgo::GncConfig& c) { c.schedule = "none"; });
  EXPECT_EQ(describeChanges(before, after), "~tf_rate 20 -> 5, ~gnc/schedule agnc -> none");
  EXPECT_TRUE(gncOptionsDiffer(before, after));
  after.gnc = before.gnc;
  EXPECT_FALSE(gncOptionsDiffer(before, after));
  after = withGnc(after, [](agnc_pgo::GncConfig& c) { c.dormant_weight = 2e-6; });
  EXPECT_EQ(describeChanges(before, after), "~tf_rate 20 -> 5, ~gnc/dormant_weight 1e-06 -> 2e-06");
  // Start-up parameters are no runtime change.
  BackendParameters startup = before;
  startup.keyframes.translation = 2.0;
  startup.map_frame = "world";
  EXPECT_EQ(describeChanges(before, startup), "");
}

// ---------------------------------------------------------------- the engine rebuild

OdometryInput odometry(int i, double x) {
  OdometryInput o;
  o.stamp = ros::Time(1000.0 + i);
  o.pose.translation = Eigen::Vector3d(x, 0.0, 0.0);
  return o;
}

// From keyframe `from` to `to` on a straight line of 1 m steps, `error` off in x.
LoopClosureInput loop(int from, int to, double error) {
  LoopClosureInput l;
  l.from_stamp = ros::Time(1000.0 + from);
  l.to_stamp = ros::Time(1000.0 + to);
  l.measurement.translation = Eigen::Vector3d(to - from + error, 0.0, 0.0);
  l.source = "test";
  return l;
}

BackendParameters everyMessageAKeyframe() {
  BackendParameters p;
  p.keyframes = KeyframeParameters();  // all criteria off
  return p;
}

void addLine(BackendGraph* g, int n) {
  for (int i = 0; i < n; ++i) {
    bool keyframe = false;
    ASSERT_EQ(g->addOdometry(odometry(i, i), &keyframe), "");
    ASSERT_TRUE(keyframe);
  }
}

void addLoop(BackendGraph* g, const LoopClosureInput& l) {
  bool added = false;
  ASSERT_EQ(g->addLoopClosure(l, &added), "");
  ASSERT_TRUE(added);
}

void solve(BackendGraph* g) {
  core::UpdateStats stats;
  std::string error;
  ASSERT_TRUE(g->update(&stats, &error)) << error;
}

TEST(RuntimeParameters, GncChangeRebuildsTheEngineFromItsExactState) {
  const BackendParameters p = everyMessageAKeyframe();
  BackendGraph g(p);
  addLine(&g, 60);
  addLoop(&g, loop(25, 0, 0.4));    // 4 sigma (x sigma 0.1): graduates under `reference`, lands
  addLoop(&g, loop(59, 35, 30.0));  // far, alone: rejected on arrival
  solve(&g);
  const auto& loops = g.engine()->loopClosures();
  ASSERT_TRUE(loops[0].inlier);
  ASSERT_FALSE(loops[1].inlier);
  ASSERT_TRUE(loops[1].uncorroborated);
  const SavedGraph before = g.save();
  const long steps = g.totalGncSteps(), iterations = g.totalIterations();
  ASSERT_GT(steps, 0);

  // A loop closure arrives while paused: pending, not solved.
  addLoop(&g, loop(45, 40, 0.0));
  ASSERT_EQ(g.pendingLoopClosures(), 1);

  const BackendParameters next = withGnc(p, [](agnc_pgo::GncConfig& c) {
    c.reset = "none";
    c.max_gnc_steps = 40;
  });
  EXPECT_TRUE(g.setParameters(next));
  EXPECT_EQ(gncOf(g.engine()->options()).max_gnc_steps, 40);
  EXPECT_EQ(gncOf(g.engine()->options()).reset, "none");
  const SavedGraph after = g.save();
  ASSERT_EQ(after.estimate.size(), before.estimate.size());
  for (size_t i = 0; i < before.estimate.size(); ++i) {
    EXPECT_EQ(after.estimate[i].translation, before.estimate[i].translation) << i;
    EXPECT_EQ(after.estimate[i].rotation.coeffs(), before.estimate[i].rotation.coeffs()) << i;
  }
  ASSERT_EQ(after.loops.size(), 3u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(after.loops[k].state.graduation.mu, before.loops[k].state.graduation.mu) << k;
    EXPECT_EQ(after.loops[k].state.graduation.step, before.loops[k].state.graduation.step) << k;
    EXPECT_EQ(after.loops[k].state.graduation.init_step, before.loops[k].state.graduation.init_step) << k;
    EXPECT_EQ(g.engine()->loopClosures()[k].inlier, k == 0) << k;
    EXPECT_EQ(g.engine()->loopClosures()[k].uncorroborated, k == 1) << k;  // the rebuilt engine knows why
  }
  EXPECT_EQ(g.pendingLoopClosures(), 1);  // still to be judged
  EXPECT_EQ(g.totalGncSteps(), steps);    // totals carried over
  EXPECT_EQ(g.totalIterations(), iterations);
  GraphSnapshotPtr snapshot = g.snapshot(true);
  int uncorroborated = 0;
  for (const SnapshotEdge& e : snapshot->edges) uncorroborated += e.uncorroborated;
  EXPECT_EQ(uncorroborated, 1);  // the rejected one still says why

  solve(&g);
  EXPECT_EQ(g.pendingLoopClosures(), 0);
  EXPECT_TRUE(g.engine()->loopClosures()[2].inlier);
  EXPECT_GE(g.totalIterations(), iterations);

  // No GNC change: no rebuild.
  BackendParameters rates = next;
  rates.tf_rate = 3.0;
  EXPECT_FALSE(g.setParameters(rates));
}

TEST(RuntimeParameters, DistanceConventionDecidesTheNextLoopClosure) {
  // The same 4-sigma loop closure: accepted under `reference` (r = 4 < q90),
  // rejected on arrival under `squared` (r^2 = 16 >= q90 = 6.25).
  BackendParameters p = everyMessageAKeyframe();
  BackendGraph g(p);
  addLine(&g, 60);
  addLoop(&g, loop(25, 0, 0.4));
  solve(&g);
  EXPECT_TRUE(g.engine()->loopClosures()[0].inlier);
  p = withGnc(p, [](agnc_pgo::GncConfig& c) { c.distance = "squared"; });
  ASSERT_TRUE(g.setParameters(p));
  addLoop(&g, loop(59, 35, 0.4));
  solve(&g);
  const core::LoopClosure& second = g.engine()->loopClosures()[1];
  EXPECT_FALSE(second.inlier);
  EXPECT_NEAR(second.distance, 4.0, 1e-6);
  EXPECT_TRUE(g.engine()->loopClosures()[0].inlier);  // landed: small residual either way
}

TEST(RuntimeParameters, StampToleranceAppliesToLaterMatches) {
  BackendParameters p = everyMessageAKeyframe();
  BackendGraph g(p);
  addLine(&g, 10);
  LoopClosureInput off = loop(5, 0, 0.0);
  off.from_stamp = ros::Time(1000.0 + 5 + 0.05);  // 50 ms off its keyframe
  bool added = false;
  EXPECT_NE(g.addLoopClosure(off, &added), "");  // default tolerance 5 ms
  EXPECT_FALSE(added);
  p.stamp_tolerance = 0.1;
  EXPECT_FALSE(g.setParameters(p));
  EXPECT_EQ(g.addLoopClosure(off, &added), "");
  EXPECT_TRUE(added);
}

}  // namespace
}  // namespace ros_backend
}  // namespace agnc_pgo
