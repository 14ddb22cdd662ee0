// Tests that read the shared datasets (../shared beside the repository, or
// -DAGNC_PGO_SHARED_DIR=...). In a clone without them these tests are
// skipped, by name and with the reason, instead of failing; scripts/test.sh
// lists the skipped tests and .ci/run fails if any was skipped there.
#pragma once

#include <filesystem>

#include <gtest/gtest.h>

#define AGNC_PGO_SKIP_WITHOUT_SHARED_DATASETS()                                              \
  if (!std::filesystem::is_directory(AGNC_PGO_SHARED_DIR))                                  \
  GTEST_SKIP() << "needs the shared datasets, and " AGNC_PGO_SHARED_DIR " is absent"
