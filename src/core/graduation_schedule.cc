#include "agnc_pgo/core/graduation_schedule.h"

#include <algorithm>

#include "agnc_pgo/core/shape_function.h"

namespace agnc_pgo {
namespace core {

GraduationSchedule::GraduationSchedule(const GncOptions::Schedule& options, int dof)
    : options_(options), dof_(dof), thresholds_(ChiSquareThresholds::forDof(dof)) {}

double GraduationSchedule::nextRisamMu(double mu) { return std::min(1.0, 2.2 * mu + 0.12); }

double GraduationSchedule::distanceOf(double r) const {
  return options_.distance == DistanceConvention::kSquared ? r * r : r;
}

double GraduationSchedule::classificationDistance(double r) const {
  return options_.classification == Classification::kWeight ? r * r : distanceOf(r);
}

void GraduationSchedule::start(GraduationState* s) const {
  s->step = (options_.kind == ScheduleKind::kRisam) ? 0 : s->init_step;
  s->steps_at_one = 0;
  s->graduating = options_.kind != ScheduleKind::kNone;
  s->mu = 0.0;
  if (options_.kind == ScheduleKind::kRisam) s->mu = s->mu_init;
}

double GraduationSchedule::adaptiveAlpha(double m) const {
  if (m < thresholds_.q25) return 0.0;
  if (m >= thresholds_.q90) return 1.0;
  return (m - thresholds_.q25) / (thresholds_.q90 - thresholds_.q25);
}

double GraduationSchedule::referenceAlpha(double m) const {
  if (m < thresholds_.q25) return 0.0;
  if (m >= thresholds_.q90) return 1.0;
  // Inside the band the reference code blends from the rapid curve (at the
  // lower edge) to the gradual one (at the upper edge) by the CDF value.
  const double t = (chiSquareCdf(dof_, m) - 0.25) / 0.65;
  return 1.0 - std::min(1.0, std::max(0.0, t));
}

void GraduationSchedule::advance(GraduationState* s, double distance) const {
  switch (options_.kind) {
    case ScheduleKind::kNone:
      s->mu = 0.0;
      break;
    case ScheduleKind::kRisam:
      // The first step of a (re)start uses mu_init itself.
      if (s->step > 0) s->mu = nextRisamMu(s->mu);
      break;
    case ScheduleKind::kAgncFixed:
      s->alpha = options_.fixed_alpha;
      s->mu = ShapeFunction::instance().muAtStep(s->alpha, s->step);
      break;
    case ScheduleKind::kAgnc:
      s->alpha = options_.reference_alpha_direction ? referenceAlpha(distance)
                                                    : adaptiveAlpha(distance);
      s->mu = ShapeFunction::instance().muAtStep(s->alpha, s->step);
      break;
  }
  ++s->step;
}

void GraduationSchedule::finishStep(GraduationState* s) const {
  if (s->mu >= 1.0) ++s->steps_at_one;
  if (s->steps_at_one >= 2 || options_.kind == ScheduleKind::kNone) s->graduating = false;
}

void GraduationSchedule::startAtOne(GraduationState* s) const {
  s->mu_init = 1.0;
  s->init_step = ShapeFunction::kStepsToOne;
}

void GraduationSchedule::adaptInitial(GraduationState* s, double m) const {
  if (!options_.adapt_initial_mu) return;
  if (options_.kind == ScheduleKind::kRisam) {
    if (m > thresholds_.q90) s->mu_init = nextRisamMu(s->mu_init);
    else if (m < thresholds_.q25) s->mu_init = std::max(0.0, s->mu_init - 0.1);
  } else if (options_.kind == ScheduleKind::kAgnc ||
             options_.kind == ScheduleKind::kAgncFixed) {
    if (m > thresholds_.q90) s->init_step = ShapeFunction::kStepsToOne;
    else if (m < thresholds_.q25) s->init_step = 0;
  }
}

}  // namespace core
}  // namespace agnc_pgo
