// Summary statistics of timing samples (replay reports, ROS ~status).
#pragma once

#include <vector>

namespace agnc_pgo {
namespace core {

// Percentile (0..100) of a sample by linear interpolation; 0 for no sample.
double percentile(std::vector<double> values, double p);

}  // namespace core
}  // namespace agnc_pgo
