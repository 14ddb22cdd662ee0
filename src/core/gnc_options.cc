#include "agnc_pgo/core/gnc_options.h"

#include <stdexcept>

namespace agnc_pgo {
namespace core {

ScheduleKind parseSchedule(const std::string& name) {
  if (name == "agnc") return ScheduleKind::kAgnc;
  if (name == "agnc-fixed") return ScheduleKind::kAgncFixed;
  if (name == "risam") return ScheduleKind::kRisam;
  if (name == "none") return ScheduleKind::kNone;
  throw std::invalid_argument("unknown schedule '" + name + "' (agnc, agnc-fixed, risam, none)");
}

DistanceConvention parseDistanceConvention(const std::string& name) {
  if (name == "reference") return DistanceConvention::kReference;
  if (name == "squared") return DistanceConvention::kSquared;
  throw std::invalid_argument("unknown distance convention '" + name + "' (reference, squared)");
}

ResetPolicy parseResetPolicy(const std::string& name) {
  if (name == "none") return ResetPolicy::kNone;
  if (name == "window") return ResetPolicy::kWindow;
  if (name == "all") return ResetPolicy::kAll;
  throw std::invalid_argument("unknown reset policy '" + name + "' (none, window, all)");
}

Classification parseClassification(const std::string& name) {
  if (name == "weight") return Classification::kWeight;
  if (name == "distance") return Classification::kDistance;
  throw std::invalid_argument("unknown classification '" + name + "' (weight, distance)");
}

std::string toString(ScheduleKind kind) {
  switch (kind) {
    case ScheduleKind::kAgnc: return "agnc";
    case ScheduleKind::kAgncFixed: return "agnc-fixed";
    case ScheduleKind::kRisam: return "risam";
    case ScheduleKind::kNone: return "none";
  }
  return "?";
}

std::string toString(DistanceConvention convention) {
  return convention == DistanceConvention::kReference ? "reference" : "squared";
}

std::string toString(ResetPolicy policy) {
  switch (policy) {
    case ResetPolicy::kNone: return "none";
    case ResetPolicy::kWindow: return "window";
    case ResetPolicy::kAll: return "all";
  }
  return "?";
}

std::string toString(Classification classification) {
  return classification == Classification::kWeight ? "weight" : "distance";
}

void validate(const GncOptions& o) {
  if (!(o.schedule.shape_c > 0.0)) throw std::invalid_argument("shape_c must be > 0");
  if (!(o.schedule.fixed_alpha >= 0.0 && o.schedule.fixed_alpha <= 1.0))
    throw std::invalid_argument("fixed_alpha must be in [0, 1]");
  if (o.solver.max_settle_iterations < 0) throw std::invalid_argument("max_settle_iterations must be >= 0");
  if (!(o.solver.convergence_step > 0.0)) throw std::invalid_argument("convergence_step must be > 0");
  if (o.window.max_poses < 0) throw std::invalid_argument("max_window_poses must be >= 0 (0: no bound)");
  if (!(o.rejection.dormant_weight >= 0.0 && o.rejection.dormant_weight < 1.0))
    throw std::invalid_argument("dormant_weight must be in [0, 1)");
  if (o.rejection.support_radius < 0) throw std::invalid_argument("support_radius must be >= 0 (0: off)");
  if (o.schedule.max_gnc_steps < 6) throw std::invalid_argument("max_gnc_steps must be >= 6");
  if (o.solver.max_iterations_per_step < 1) throw std::invalid_argument("max_iterations_per_step must be >= 1");
  if (!(o.solver.trust_region_radius > 0.0)) throw std::invalid_argument("trust_region_radius must be > 0");
  if (!(o.solver.max_trust_region_radius >= o.solver.trust_region_radius))
    throw std::invalid_argument("max_trust_region_radius must be >= trust_region_radius");
}

}  // namespace core
}  // namespace agnc_pgo
