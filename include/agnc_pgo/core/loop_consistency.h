// Pairwise consistency of two loop closures (the test of PCM, Mangelson et
// al. 2018, restricted to neighbouring loop closures).
//
// Two loop closures a (fa -> ta, z_a) and b (fb -> tb, z_b) whose endpoints
// lie close to each other along the trajectory predict each other through
// the short trajectory segments between their endpoints:
//
//   z_b ~ (T_fb^-1 T_fa) z_a (T_ta^-1 T_tb)
//
// The segments come from the current estimate; over a few poses they are
// as good as the odometry, whatever the drift of the map, so the test holds
// for true loop closures that the map does not yet agree with (a ring closed
// after a long drift) and fails for random false ones. The cycle error
// e = Log(z_b^-1 * prediction) is whitened with Sigma_a + Sigma_b (the two
// measurement covariances summed without transport: a gate, not an
// estimator). A reversed pair (fa near tb, ta near fb) uses z_a^-1.
#pragma once

#include <functional>

#include "agnc_pgo/core/pose.h"
#include "agnc_pgo/core/pose_graph.h"

namespace agnc_pgo {
namespace core {

// Whether the endpoints of a and b are pairwise within `radius` poses
// (either orientation), i.e. whether cycleDistance() applies.
bool areNeighbours(const Edge& a, const Edge& b, int radius);

// The whitened norm of the cycle error (see above); `pose(id)` returns the
// current estimate of a pose. Meaningful for neighbours (areNeighbours()).
double cycleDistance(int dimension, const Edge& a, const Edge& b,
                     const std::function<Pose(int)>& pose);

}  // namespace core
}  // namespace agnc_pgo
