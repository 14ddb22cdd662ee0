// agnc_pgo_replay: replays a g2o graph (with injected outliers) or a riSAM
// .irl log through the incremental GNC engine and reports accuracy and
// runtime. See --help.
#include <sys/resource.h>

#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "agnc_pgo/core/atomic_file.h"
#include "agnc_pgo/core/batch_solver.h"
#include "agnc_pgo/core/g2o_io.h"
#include "agnc_pgo/eval/irl_io.h"
#include "agnc_pgo/eval/metrics.h"
#include "agnc_pgo/eval/outlier_injection.h"
#include "agnc_pgo/eval/replay.h"

namespace {

using namespace agnc_pgo::core;

const char* kUsage =
    "usage: agnc_pgo_replay --input FILE.g2o|FILE.irl [--outliers PERCENT] [--seed N]\n"
    "                       [--outlier-mode random|local|random-grouped|local-grouped] [--group-size N]\n"
    "                       [--schedule agnc|agnc-fixed|risam|none] [--ground-truth GT.g2o]\n"
    "                       [--output DIR] [--quiet]\n"
    "                       [--distance reference|squared] [--classification weight|distance]\n"
    "                       [--reset none|window|all]\n"
    "                       [--full-window] [--max-window POSES] [--no-global-refinement] [--settle N]\n"
    "                       [--iterations-per-step N] [--no-trust-region] [--trust-region-radius R] [--max-trust-region-radius R]\n"
    "                       [--dormant-weight W] [--support-radius POSES] [--reference-alpha]\n";

struct Arguments {
  std::string input, ground_truth, output;
  double outliers = -1;  // < 0: not given
  unsigned long seed = 1;
  OutlierMode outlier_mode = OutlierMode::kRandom;
  int group_size = kDefaultGroupSize;
  bool group_size_given = false;
  bool quiet = false;
  GncOptions gnc;
};

double parseNumber(const std::string& flag, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v))
    throw std::invalid_argument(flag + " expects a number, got '" + text + "'");
  return v;
}

// A whole non-negative decimal integer no larger than `max` ("-1", "1.5",
// "1e3" and overflow are refused rather than wrapped or truncated).
unsigned long long parseCount(const std::string& flag, const std::string& text, unsigned long long max) {
  char* end = nullptr;
  errno = 0;
  const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  const bool digits_only = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
  if (!digits_only || *end != '\0' || errno == ERANGE || v > max)
    throw std::invalid_argument(flag + " expects a non-negative integer up to " + std::to_string(max) + ", got '" +
                                text + "'");
  return v;
}

int parseInt(const std::string& flag, const std::string& text) {
  return static_cast<int>(parseCount(flag, text, static_cast<unsigned long long>(INT_MAX)));
}

double parsePercent(const std::string& flag, const std::string& text) {
  const double v = parseNumber(flag, text);
  if (!(v >= 0.0 && v < 100.0)) throw std::invalid_argument(flag + " must be in [0, 100), got '" + text + "'");
  return v;
}

OutlierMode parseOutlierModeFlag(const std::string& flag, const std::string& text) {
  try {
    return parseOutlierMode(text);
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument(flag + " expects random, local, random-grouped or local-grouped, got '" + text + "'");
  }
}

Arguments parseArguments(int argc, char** argv) {
  Arguments a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--input") a.input = value();
    else if (flag == "--outliers") a.outliers = parsePercent(flag, value());
    else if (flag == "--seed") a.seed = static_cast<unsigned long>(parseCount(flag, value(), ULONG_MAX));
    else if (flag == "--outlier-mode") a.outlier_mode = parseOutlierModeFlag(flag, value());
    else if (flag == "--group-size") {
      a.group_size = parseInt(flag, value());
      a.group_size_given = true;
    }
    else if (flag == "--schedule") a.gnc.schedule.kind = parseSchedule(value());
    else if (flag == "--ground-truth") a.ground_truth = value();
    else if (flag == "--output") a.output = value();
    else if (flag == "--quiet") a.quiet = true;
    else if (flag == "--distance") a.gnc.schedule.distance = parseDistanceConvention(value());
    else if (flag == "--classification") a.gnc.schedule.classification = parseClassification(value());
    else if (flag == "--reset") a.gnc.schedule.reset = parseResetPolicy(value());
    else if (flag == "--full-window") a.gnc.window.local = false;
    else if (flag == "--max-window") a.gnc.window.max_poses = parseInt(flag, value());
    else if (flag == "--settle") a.gnc.solver.max_settle_iterations = parseInt(flag, value());
    else if (flag == "--no-global-refinement") a.gnc.window.global_refinement = false;
    else if (flag == "--no-trust-region") a.gnc.solver.trust_region = false;
    else if (flag == "--trust-region-radius") a.gnc.solver.trust_region_radius = parseNumber(flag, value());
    else if (flag == "--max-trust-region-radius") a.gnc.solver.max_trust_region_radius = parseNumber(flag, value());
    else if (flag == "--iterations-per-step") a.gnc.solver.max_iterations_per_step = parseInt(flag, value());
    else if (flag == "--reference-alpha") a.gnc.schedule.reference_alpha_direction = true;
    else if (flag == "--support-radius") a.gnc.rejection.support_radius = parseInt(flag, value());
    else if (flag == "--dormant-weight") a.gnc.rejection.dormant_weight = parseNumber(flag, value());
    else if (flag == "--help" || flag == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else {
      throw std::invalid_argument("unknown argument '" + flag + "'");
    }
  }
  if (a.input.empty()) throw std::invalid_argument("--input is required");
  if (a.outliers >= 100.0) throw std::invalid_argument("--outliers must be in [0, 100)");
  if (a.group_size_given && a.group_size < 1)
    throw std::invalid_argument("--group-size must be at least 1, got " + std::to_string(a.group_size));
  if (a.group_size_given && !isGrouped(a.outlier_mode))
    throw std::invalid_argument("--group-size applies only to --outlier-mode random-grouped or local-grouped");
  validate(a.gnc);
  return a;
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string stem(const std::string& path) { return std::filesystem::path(path).stem().string(); }

// Loads the input as a log; injects outliers into g2o graphs.
IncrementalLog loadLog(const Arguments& a) {
  if (endsWith(a.input, ".irl")) {
    if (a.outliers > 0)
      throw std::invalid_argument("--outliers does not apply to .irl logs (their outliers are labelled in the file)");
    if (a.outlier_mode != OutlierMode::kRandom || a.group_size_given)
      throw std::invalid_argument("--outlier-mode and --group-size do not apply to .irl logs");
    return readIrl(a.input);
  }
  PoseGraph graph = readG2o(a.input);
  const double percent = a.outliers < 0 ? 0.0 : a.outliers;
  if (percent > 0) {
    OutlierOptions options;
    options.percent = percent;
    options.seed = a.seed;
    options.mode = a.outlier_mode;
    options.group_size = a.group_size;
    graph = injectOutliersAgainstOptimum(graph, stem(a.input), options);
  }
  return logFromGraph(graph, stem(a.input));
}

std::string jsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s << std::setprecision(10) << v;
  return s.str();
}

// CSV cells: a non-finite value is written as an empty cell (no inf or nan
// reaches an output).
std::string csvNumber(double v) { return std::isfinite(v) ? jsonNumber(v) : ""; }

// The redundancy of the outlier-free graph: observations (odometry, true loop
// closures, one prior per odometry chain) minus unknowns, in scalar degrees of
// freedom. Its chi2 per redundancy is the a-posteriori variance factor: about
// 1 when the stated covariances match the noise, far from 1 when they do not.
long outlierFreeRedundancy(const IncrementalLog& log) {
  long observations = 0;
  for (const LogEntry& entry : log.entries)
    if (!(entry.type == EntryType::kLoopClosure && entry.edge.is_outlier)) ++observations;
  const long tangent = log.dimension == 2 ? 3 : 6;
  return tangent * (observations - log.numPoses());
}

// metrics.json, estimate.g2o, trajectory.tum, reference.g2o,
// loop_closures.csv and latency.csv in DIR, each written atomically; a
// failed write throws naming the file.
void writeOutputs(const std::string& dir_name, const std::string& json, const IncrementalLog& log,
                  const ReplayResult& result, const PoseGraph& inlier_optimum) {
  namespace fs = std::filesystem;
  fs::create_directories(dir_name);
  const fs::path dir(dir_name);
  writeFileAtomically((dir / "metrics.json").string(), json);
  writeG2o(resultGraph(log, result), (dir / "estimate.g2o").string());
  writeTumTrajectory(result.estimate, (dir / "trajectory.tum").string());
  writeG2o(inlier_optimum, (dir / "reference.g2o").string());

  // The input file's ids, as estimate.g2o writes them.
  const auto fileId = [&log](int index) { return log.file_ids.empty() ? index : log.file_ids[index]; };
  std::ostringstream csv;
  csv << "from,to,outlier,mu,weight,distance,inlier,uncorroborated\n";
  for (const LoopClosureResult& l : result.loop_closures)
    csv << fileId(l.edge.from) << ',' << fileId(l.edge.to) << ',' << (l.edge.is_outlier ? 1 : 0) << ','
        << csvNumber(l.mu) << ',' << csvNumber(l.weight) << ',' << csvNumber(l.distance) << ','
        << (l.inlier ? 1 : 0) << ',' << (l.uncorroborated ? 1 : 0) << '\n';
  writeFileAtomically((dir / "loop_closures.csv").string(), csv.str());

  std::ostringstream latency;
  latency << "poses,update_ms,first_estimate_ms,free_poses,iterations,refinement_iterations,gnc_steps,graduated\n";
  for (size_t i = 0; i < result.loop_update_ms.size(); ++i) {
    const UpdateStats& s = result.loop_update_stats[i];
    latency << result.loop_update_poses[i] << ',' << csvNumber(result.loop_update_ms[i]) << ','
            << csvNumber(result.first_estimate_ms[i]) << ',' << result.loop_update_poses[i] - s.first_variable << ','
            << s.iterations << ',' << s.refinement_iterations << ',' << s.gnc_steps << ',' << s.graduated << '\n';
  }
  writeFileAtomically((dir / "latency.csv").string(), latency.str());
}

double peakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // ru_maxrss is in KiB on Linux
}

// The engine's run over the log, with a progress line unless quiet.
ReplayResult runReplay(const IncrementalLog& log, const Arguments& args) {
  ReplayOptions options;
  options.gnc = args.gnc;
  auto last_print = std::chrono::steady_clock::now();
  if (!args.quiet) {
    options.progress = [&last_print](size_t done, size_t total) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_print < std::chrono::seconds(1) && done != total) return;
      last_print = now;
      std::cerr << "\r  replay " << done << "/" << total << " entries" << (done == total ? "\n" : "")
                << std::flush;
    };
  }
  return replay(log, options);
}

// What the estimate is measured against: the outlier-free least-squares
// optimum, the lowest of Levenberg-Marquardt from the odometry, the global
// initialisation and the ground truth (LM from the odometry alone can end in
// a local minimum), with every start's chi2, so that a bad reference shows.
struct Reference {
  PoseGraph optimum;
  GlobalBatchResult batch;
  long redundancy = 0;
  double chi2_per_redundancy = NAN;
  std::string start_json, start_text;
};

Reference computeReference(const IncrementalLog& log, const PoseGraph* ground_truth) {
  Reference reference;
  reference.optimum = graphFromLog(log);
  BatchOptions batch;
  batch.skip_outliers = true;
  reference.batch = optimizeBatchGlobal(&reference.optimum, batch, ground_truth ? &ground_truth->poses : nullptr);
  std::ostringstream start_json, start_text;
  for (const BatchStartResult& s : reference.batch.starts) {
    const char* separator = &s == &reference.batch.starts.front() ? "" : ", ";
    start_json << separator << '"' << toString(s.start) << "\": " << jsonNumber(s.chi2);
    start_text << separator << toString(s.start) << ' ' << (s.error.empty() ? jsonNumber(s.chi2) : s.error);
  }
  reference.start_json = start_json.str();
  reference.start_text = start_text.str();
  reference.redundancy = outlierFreeRedundancy(log);
  if (reference.redundancy > 0)
    reference.chi2_per_redundancy = reference.batch.chi2 / static_cast<double>(reference.redundancy);
  return reference;
}

// Accuracy against the ground truth (NaN without one) and the reference,
// and the latency percentiles.
struct Summary {
  double ate = NAN, rpe = NAN, ate_inlier_optimum = NAN;
  double p50 = NAN, p95 = NAN, pmax = NAN;  // loop-closure updates, ms
  double f50 = NAN, f95 = NAN, fmax = NAN;  // the first estimate of each, ms
};

Summary summarize(const IncrementalLog& log, const ReplayResult& result, const PoseGraph* ground_truth,
                  const Reference& reference) {
  Summary s;
  if (ground_truth) {
    s.ate = absoluteTrajectoryError(result.estimate, ground_truth->poses, log.dimension);
    s.rpe = relativePoseError(result.estimate, ground_truth->poses);
  }
  s.ate_inlier_optimum = absoluteTrajectoryError(result.estimate, reference.optimum.poses, log.dimension);
  s.p50 = percentile(result.loop_update_ms, 50);
  s.p95 = percentile(result.loop_update_ms, 95);
  s.pmax = percentile(result.loop_update_ms, 100);
  s.f50 = percentile(result.first_estimate_ms, 50);
  s.f95 = percentile(result.first_estimate_ms, 95);
  s.fmax = percentile(result.first_estimate_ms, 100);
  return s;
}

// metrics.json (also printed with --quiet).
std::string metricsJson(const Arguments& args, const IncrementalLog& log, const ReplayResult& result,
                        const Reference& reference, const Summary& s) {
  std::ostringstream json;
  json << "{\n"
       << "  \"dataset\": \"" << log.name << "\",\n"
       << "  \"input\": \"" << std::filesystem::path(args.input).filename().string() << "\",\n"
       << "  \"dimension\": " << log.dimension << ",\n"
       << "  \"poses\": " << log.numPoses() << ",\n"
       << "  \"loop_closures\": " << log.numLoopClosures() << ",\n"
       << "  \"outliers\": " << log.numOutliers() << ",\n"
       << "  \"outlier_percent\": " << jsonNumber(args.outliers < 0 ? NAN : args.outliers) << ",\n"
       << "  \"seed\": " << args.seed << ",\n"
       << "  \"outlier_mode\": \"" << toString(args.outlier_mode) << "\",\n"
       << "  \"group_size\": " << (isGrouped(args.outlier_mode) ? std::to_string(args.group_size) : "null")
       << ",\n"
       << "  \"schedule\": \"" << toString(args.gnc.schedule.kind) << "\",\n"
       << "  \"distance\": \"" << toString(args.gnc.schedule.distance) << "\",\n"
       << "  \"classification\": \"" << toString(args.gnc.schedule.classification) << "\",\n"
       << "  \"reset\": \"" << toString(args.gnc.schedule.reset) << "\",\n"
       << "  \"local_window\": " << (args.gnc.window.local ? "true" : "false") << ",\n"
       << "  \"max_window_poses\": " << args.gnc.window.max_poses << ",\n"
       << "  \"runtime_s\": " << jsonNumber(result.runtime_s) << ",\n"
       << "  \"idle_refinement_ms\": " << jsonNumber(result.idle_refinement_ms) << ",\n"
       << "  \"idle_refinement_iterations\": " << result.idle_refinement_iterations << ",\n"
       << "  \"solves\": " << result.solves << ",\n"
       << "  \"gnc_steps\": " << result.gnc_steps << ",\n"
       << "  \"noise_scale\": [" << jsonNumber(result.noise_scale(0)) << ", "
       << jsonNumber(result.noise_scale(result.noise_scale.size() - 1)) << "],\n"
       << "  \"mean_free_poses\": " << jsonNumber(result.mean_free_poses) << ",\n"
       << "  \"solves_per_update_histogram\": [";
  for (size_t k = 0; k < result.solves_per_update_histogram.size(); ++k)
    json << (k ? ", " : "") << result.solves_per_update_histogram[k];
  json << "],\n"
       << "  \"precision\": " << jsonNumber(result.counts.precision()) << ",\n"
       << "  \"recall\": " << jsonNumber(result.counts.recall()) << ",\n"
       << "  \"true_positives\": " << result.counts.true_positive << ",\n"
       << "  \"false_positives\": " << result.counts.false_positive << ",\n"
       << "  \"false_negatives\": " << result.counts.false_negative << ",\n"
       << "  \"ate_m\": " << jsonNumber(s.ate) << ",\n"
       << "  \"rpe_m\": " << jsonNumber(s.rpe) << ",\n"
       << "  \"ate_vs_inlier_optimum_m\": " << jsonNumber(s.ate_inlier_optimum) << ",\n"
       << "  \"reference_chi2\": " << jsonNumber(reference.batch.chi2) << ",\n"
       << "  \"reference_redundancy\": " << reference.redundancy << ",\n"
       << "  \"reference_chi2_per_redundancy\": " << jsonNumber(reference.chi2_per_redundancy) << ",\n"
       << "  \"reference_start\": \"" << toString(reference.batch.best) << "\",\n"
       << "  \"reference_start_chi2\": {" << reference.start_json << "},\n"
       << "  \"update_ms_p50\": " << jsonNumber(s.p50) << ",\n"
       << "  \"update_ms_p95\": " << jsonNumber(s.p95) << ",\n"
       << "  \"update_ms_max\": " << jsonNumber(s.pmax) << ",\n"
       << "  \"first_estimate_ms_p50\": " << jsonNumber(s.f50) << ",\n"
       << "  \"first_estimate_ms_p95\": " << jsonNumber(s.f95) << ",\n"
       << "  \"first_estimate_ms_max\": " << jsonNumber(s.fmax) << ",\n"
       << "  \"peak_rss_mb\": " << jsonNumber(peakRssMb()) << "\n"
       << "}\n";
  return json.str();
}

// The human-readable report (without --quiet).
void printReport(const Arguments& args, const IncrementalLog& log, const ReplayResult& result,
                 const Reference& reference, const Summary& s, bool has_ground_truth) {
  std::printf("%-28s %s (%dD), %d poses, %d loop closures (%d outliers)\n", "input:", log.name.c_str(),
              log.dimension, log.numPoses(), log.numLoopClosures(), log.numOutliers());
  std::printf("%-28s %s\n", "schedule:", toString(args.gnc.schedule.kind).c_str());
  std::printf("%-28s %.3f s (%ld solves, %ld GNC steps, %.0f free poses per solve)\n", "runtime:",
              result.runtime_s, result.solves, result.gnc_steps, result.mean_free_poses);
  std::printf("%-28s %.2f / %.2f / %.2f ms\n", "loop update p50/p95/max:", s.p50, s.p95, s.pmax);
  std::printf("%-28s %.2f / %.2f / %.2f ms\n", "first estimate p50/p95/max:", s.f50, s.f95, s.fmax);
  std::printf("%-28s %.2f ms (%d whole-graph iterations; included in the runtime)\n",
              "idle refinement at the end:", result.idle_refinement_ms, result.idle_refinement_iterations);
  std::printf("%-28s %.4f (TP %d, FP %d)\n", "precision:", result.counts.precision(),
              result.counts.true_positive, result.counts.false_positive);
  std::printf("%-28s %.4f (FN %d)\n", "recall:", result.counts.recall(), result.counts.false_negative);
  if (has_ground_truth) std::printf("%-28s %.4f m / %.4f m\n", "ATE / RPE vs ground truth:", s.ate, s.rpe);
  std::printf("%-28s %.4f m\n", "ATE vs outlier-free optimum:", s.ate_inlier_optimum);
  std::printf("%-28s chi2 %.7g from the %s start (%s)\n", "outlier-free optimum:", reference.batch.chi2,
              toString(reference.batch.best).c_str(), reference.start_text.c_str());
  if (reference.redundancy > 0)
    std::printf("%-28s %.4g (redundancy %ld; about 1 when the stated covariances match the noise)\n",
                "  chi2 per redundancy:", reference.chi2_per_redundancy, reference.redundancy);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Arguments args = parseArguments(argc, argv);
    std::unique_ptr<PoseGraph> ground_truth;
    if (!args.ground_truth.empty())
      ground_truth = std::make_unique<PoseGraph>(readG2o(args.ground_truth));
    const IncrementalLog log = loadLog(args);
    if (ground_truth && static_cast<int>(ground_truth->poses.size()) != log.numPoses())
      throw std::invalid_argument("ground truth has " + std::to_string(ground_truth->poses.size()) +
                                  " poses, the input " + std::to_string(log.numPoses()));
    if (ground_truth && ground_truth->file_ids != log.file_ids)
      throw std::invalid_argument("ground truth and input number their poses differently (vertex ids)");

    const ReplayResult result = runReplay(log, args);
    const Reference reference = computeReference(log, ground_truth.get());
    const Summary summary = summarize(log, result, ground_truth.get(), reference);
    const std::string json = metricsJson(args, log, result, reference, summary);
    if (!args.output.empty()) writeOutputs(args.output, json, log, result, reference.optimum);
    if (args.quiet) std::cout << json;
    else printReport(args, log, result, reference, summary, ground_truth != nullptr);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "agnc_pgo_replay: " << e.what() << "\n";
    return 1;
  }
}
