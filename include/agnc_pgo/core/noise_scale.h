// How many times the stated covariances understate the noise, from the
// cycles of neighbouring loop closures (loop_consistency.h).
//
// Whitened with the stated covariances, the cycle error of two true
// neighbouring loop closures has d^2 ~ chi^2(dof) where the covariances are
// right and d^2 ~ k chi^2(dof) where they are k times too tight (in
// variance). A false loop closure only makes a pair's d^2 larger, a group of
// mutually consistent false ones smaller. Each loop closure gives one
// sample, the least d^2 over its m earlier neighbours: a group of false loop
// closures has many pairs among its members, and counted once each they are
// no more of the samples than false loop closures are of the loop closures.
// The estimate is the least factor k that brings a quarter of the samples
// below their own lower quartile (that of the least of m draws of
// k chi^2(dof)), less three standard deviations of that count (a
// distribution-free lower confidence bound, by the normal approximation of
// the binomial), and never below 1: stated covariances are trusted unless
// the data show them too tight, however wide they are. False samples only
// raise it: it holds with up to three quarters of them false -- over the
// run, not over every stretch of it: the engine re-estimates as the samples
// double and takes the latest estimate, lower or higher, so a first stretch
// of false loop closures that misleads an early estimate is outvoted by the
// samples after it. (All pairs
// as samples, and their median, were measured too: groups of false loop
// closures then made most of M3500's pairs and widened a graph whose noise
// is stated six times too wide.)
#pragma once

#include <vector>

namespace agnc_pgo {
namespace core {

class NoiseScale {
 public:
  explicit NoiseScale(int dof);

  // One loop closure's sample: the least squared cycle error over its
  // `pairs` neighbours, whitened with the stated covariances. Non-finite
  // values (no odometry chain between the endpoints) are skipped.
  void add(double d2, int pairs = 1);
  int samples() const { return static_cast<int>(samples_.size()); }

  // The variance factor the samples so far prove (>= 1; 1 until there are
  // enough of them for the bound to have a rank, 35 or more).
  double estimate() const;

 private:
  struct Sample {
    double d2;
    int pairs;
  };
  // How many samples lie below their own lower quartile under scale k.
  int belowQuartile(double k) const;

  int dof_;
  std::vector<Sample> samples_;
};

}  // namespace core
}  // namespace agnc_pgo
