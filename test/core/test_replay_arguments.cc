// agnc_pgo_replay's argument parsing: out-of-range or malformed numbers are
// refused with one line and exit status 1 (they used to be taken as "not
// given" or wrapped around: --outliers -5, --seed -1).
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

namespace {

struct Run {
  int status;
  std::string output;
};

Run replay(const std::string& arguments) {
  const std::string command = std::string(AGNC_PGO_REPLAY) + " --input " + AGNC_PGO_SHARED_DIR +
                              "/datasets/ring.g2o --quiet --output /nonexistent_agnc_dir " + arguments + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  Run run{-1, ""};
  if (!pipe) return run;
  char buffer[256];
  while (std::fgets(buffer, sizeof buffer, pipe)) run.output += buffer;
  const int status = ::pclose(pipe);
  run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

void expectRefused(const std::string& arguments, const std::string& reason) {
  const Run run = replay(arguments);
  EXPECT_EQ(run.status, 1) << arguments << ": " << run.output;
  EXPECT_NE(run.output.find(reason), std::string::npos) << arguments << ": " << run.output;
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
