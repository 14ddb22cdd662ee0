// For the tests that CHOLMOD runs serially on the thread that factorises
// (keepCholmodSerial) and on that thread only.
#pragma once

#include <functional>
#include <thread>

#include <omp.h>

namespace agnc_pgo {
namespace core {

struct OmpLevels {
  int on_working_thread = -1;  // max-active-levels after `work` on its own thread
  int on_other_thread = -1;    // ... on a fresh thread afterwards
};

inline OmpLevels ompLevelsAfter(const std::function<void()>& work) {
  OmpLevels levels;
  std::thread working([&] {
    work();
    levels.on_working_thread = omp_get_max_active_levels();
  });
  working.join();
  std::thread other([&] { levels.on_other_thread = omp_get_max_active_levels(); });
  other.join();
  return levels;
}

}  // namespace core
}  // namespace agnc_pgo
