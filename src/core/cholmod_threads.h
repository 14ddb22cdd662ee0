// Internal to the core's batch solver, whose Ceres solve factorises with
// CHOLMOD.
#pragma once

#include <omp.h>

namespace agnc_pgo {
namespace core {

// CHOLMOD 3 (Debian 12's SuiteSparse 5.12) runs loops of its supernodal
// factorisation on a team of 4 OpenMP threads fixed when it was compiled,
// whatever OMP_NUM_THREADS says. On two cores they oversubscribe the machine
// (about 4 million futex calls in one Sphere2500 replay) and made the replay
// slower and erratic (Sphere2500 at 10 %: 21-34 s, serial 14-16 s). Zero
// active levels make every parallel region this thread starts run on the
// thread alone; libgomp keeps that setting per thread, so the other threads
// of the process (a nodelet manager's) keep their parallelism.
inline void keepCholmodSerial() { omp_set_max_active_levels(0); }

}  // namespace core
}  // namespace agnc_pgo
