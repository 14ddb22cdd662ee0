// TUM trajectory export.
#include "agnc_pgo/core/trajectory_io.h"

#include "agnc_pgo/core/atomic_file.h"

#include <cmath>
#include <iomanip>
#include <sstream>
#include <limits>
#include <stdexcept>

namespace agnc_pgo {
namespace core {

void writeTumTrajectory(const Poses& poses, const std::string& path, const std::vector<double>& stamps) {
  if (!stamps.empty() && stamps.size() != poses.size()) {
    throw std::invalid_argument("writeTumTrajectory: " + std::to_string(stamps.size()) + " stamps for " +
                                std::to_string(poses.size()) + " poses");
  }
  std::ostringstream out;
  // max_digits10 makes the text round-trip to the same doubles.
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const Eigen::Vector3d& t = poses[k].translation;
    const Eigen::Quaterniond& q = poses[k].rotation;
    const double stamp = stamps.empty() ? static_cast<double>(k) : stamps[k];
    if (!t.allFinite() || !q.coeffs().allFinite() || !std::isfinite(stamp))
      throw std::invalid_argument("writeTumTrajectory: pose " + std::to_string(k) + " is not finite");
    out << stamp << ' ' << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x() << ' ' << q.y() << ' '
        << q.z() << ' ' << q.w() << '\n';
  }
  try {
    writeFileAtomically(path, out.str());  // checks every write, fsync and close (/dev/full fails)
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(std::string("writeTumTrajectory: ") + error.what());
  }
}

}  // namespace core
}  // namespace agnc_pgo
