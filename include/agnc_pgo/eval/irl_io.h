// riSAM's .irl incremental log format (ALGORITHM.md §5).
#pragma once

#include <istream>
#include <string>

#include "agnc_pgo/core/g2o_io.h"  // ParseError
#include "agnc_pgo/eval/incremental_log.h"

namespace agnc_pgo {
namespace core {

// Reads an .irl log. Covariances are inverted into g2o-ordered information
// matrices (SE(3): the file's rotation-first order is permuted to x y z rx ry
// rz). A LOOP entry keeps its ground-truth label (correct = 1: outlier).
// Errors name file, line and reason (ParseError).
IncrementalLog readIrl(const std::string& path);
IncrementalLog readIrl(std::istream& in, const std::string& name);

}  // namespace core
}  // namespace agnc_pgo
