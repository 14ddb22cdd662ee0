// agnc_pgo_replay's argument parsing: out-of-range or malformed numbers are
// refused with one line and exit status 1 (they used to be taken as "not
// given" or wrapped around: --outliers -5, --seed -1). And its outputs: every
// file written whole, a failed write an error.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace {

struct ToolRun {
  int status;
  std::string output;
};

ToolRun run(const std::string& arguments) {
  const std::string command = std::string(AGNC_PGO_REPLAY) + " " + arguments + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  ToolRun result{-1, ""};
  if (!pipe) return result;
  char buffer[256];
  while (std::fgets(buffer, sizeof buffer, pipe)) result.output += buffer;
  const int status = ::pclose(pipe);
  result.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

void expectRefused(const std::string& arguments, const std::string& reason) {
  const ToolRun refused = run(std::string("--input ") + AGNC_PGO_SHARED_DIR +
                          "/datasets/ring.g2o --quiet --output /nonexistent_agnc_dir " + arguments);
  EXPECT_EQ(refused.status, 1) << arguments << ": " << refused.output;
  EXPECT_NE(refused.output.find(reason), std::string::npos) << arguments << ": " << refused.output;
}

namespace fs = std::filesystem;

// A 2-D square walked twice (8 unit steps, turning left at every corner) with
// two loop closures back to the first lap: small enough to replay in a test,
// needs nothing from ../shared.
struct TempSquare {
  fs::path dir = fs::temp_directory_path() / ("agnc_replay_outputs_" + std::to_string(::getpid()));
  fs::path graph = dir / "square.g2o";
  TempSquare() {
    fs::create_directories(dir);
    std::ofstream g(graph);
    for (int i = 0; i <= 8; ++i) g << "VERTEX_SE2 " << i << " 0 0 0\n";
    const char* info = " 100 0 0 100 0 400\n";
    for (int i = 0; i < 8; ++i) g << "EDGE_SE2 " << i << ' ' << i + 1 << (i % 2 ? " 1.02 0.01 1.5608" : " 0.99 -0.01 0") << info;
    g << "EDGE_SE2 8 0 0.01 0.02 0.01" << info;
    g << "EDGE_SE2 6 2 0.02 -0.01 -0.02" << info;
  }
  ~TempSquare() { fs::remove_all(dir); }
};

std::string readAll(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(ReplayOutputs, EveryFileIsWrittenWholeWithTheReferencesRedundancy) {
  TempSquare square;
  const fs::path out = square.dir / "out";
  const ToolRun ok = run("--input " + square.graph.string() + " --quiet --output " + out.string());
  ASSERT_EQ(ok.status, 0) << ok.output;
  for (const char* name : {"metrics.json", "estimate.g2o", "trajectory.tum", "reference.g2o", "loop_closures.csv",
                           "latency.csv"})
    EXPECT_TRUE(fs::is_regular_file(out / name)) << name;
  for (const fs::directory_entry& entry : fs::directory_iterator(out))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
  // Two true loop closures of 3 degrees of freedom each: redundancy 6.
  const std::string metrics = readAll(out / "metrics.json");
  EXPECT_NE(metrics.find("\"reference_redundancy\": 6,"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("\"reference_chi2_per_redundancy\": "), std::string::npos) << metrics;
  const std::string csv = readAll(out / "loop_closures.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3) << csv;  // header + 2 loop closures
  EXPECT_EQ(csv.find("inf"), std::string::npos) << csv;
  EXPECT_EQ(csv.find("nan"), std::string::npos) << csv;
}

TEST(ReplayOutputs, AFailedWriteIsAnErrorNamingTheFile) {
  TempSquare square;
  const fs::path out = square.dir / "out";
  fs::create_directories(out / "metrics.json");  // a directory where the file must go
  const ToolRun failed = run("--input " + square.graph.string() + " --quiet --output " + out.string());
  EXPECT_EQ(failed.status, 1) << failed.output;
  EXPECT_NE(failed.output.find("metrics.json"), std::string::npos) << failed.output;
}

TEST(ReplayArguments, RefusesOutOfRangeAndMalformedNumbers) {
  expectRefused("--outliers -5", "--outliers must be in [0, 100), got '-5'");
  expectRefused("--outliers 100", "--outliers must be in [0, 100)");
  expectRefused("--seed -1", "--seed expects a non-negative integer");
  expectRefused("--seed 1.5", "--seed expects a non-negative integer");
  expectRefused("--seed 99999999999999999999999", "--seed expects a non-negative integer");
  expectRefused("--max-window 1e12", "--max-window expects a non-negative integer");
  expectRefused("--support-radius -3", "--support-radius expects a non-negative integer");
}

}  // namespace
