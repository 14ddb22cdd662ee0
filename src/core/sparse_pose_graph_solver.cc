#include "agnc_pgo/core/sparse_pose_graph_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <type_traits>
#include <utility>
#include <stdexcept>
#include <string>

#include <Eigen/LU>
#include <Eigen/SparseCholesky>

#include <amd.h>

#include "block_simplicial_llt.h"

namespace agnc_pgo {
namespace core {
namespace {

// Dogleg trust-region control (Nocedal & Wright, Alg. 4.1): a step whose
// actual cost decrease is at least kGoodRatio of the model's prediction lets
// the radius grow to kGrowth times the step; below kPoorRatio it shrinks to
// kShrink times the step. A rejected step is retried inside the smaller
// radius at most kMaxDampingAttempts times per iteration.
constexpr double kGoodRatio = 0.75;
constexpr double kPoorRatio = 0.25;
constexpr double kGrowth = 3.0;
constexpr double kShrink = 0.5;
constexpr int kMaxDampingAttempts = 6;
constexpr double kMinRadius = 1e-4;

// A Gauss-Newton step found by conjugate gradients is taken once its
// residual |H x - b| is this small relative to |b|: as exact as a solve
// with a new factor, for the purposes of the step. The tolerance of an
// inexact step (chooseForcingTerm) lies between it and kMaxForcing, the
// bound of Eisenstat & Walker (1996); their safeguard keeps the tolerance
// from falling faster than the previous one to the power kForcingPower
// while that is above kForcingSafeguard.
constexpr double kStepTolerance = 1e-10;
constexpr double kMaxForcing = 0.9;
constexpr double kForcingPower = 1.618033988749895;  // (1 + sqrt 5) / 2
constexpr double kForcingSafeguard = 0.1;

// Sums of a sequence that grows at its end (a Fenwick tree): add to one
// element and the sum of the first `count` elements, each in log(size).
class GrowingPrefixSums {
 public:
  // Appends an element of value 0. The new node holds the sum of the
  // elements its range covers before it, all of them already in place.
  void append() {
    const size_t i = tree_.size() + 1;
    tree_.push_back(prefix(i - 1) - prefix(i - lowBit(i)));
  }
  void add(size_t index, double delta) {
    for (size_t i = index + 1; i <= tree_.size(); i += lowBit(i)) tree_[i - 1] += delta;
  }
  double prefix(size_t count) const {
    double sum = 0.0;
    for (size_t i = count; i > 0; i -= lowBit(i)) sum += tree_[i - 1];
    return sum;
  }
  size_t size() const { return tree_.size(); }

 private:
  static size_t lowBit(size_t i) { return i & (~i + 1); }
  std::vector<double> tree_;
};

}  // namespace

struct SparsePoseGraphSolver::VarianceTerms {
  // Per factor, the terms last summed: w r^2 and w dim (robust), r^2 and 0
  // (plain), nothing for a disabled or dormant one.
  std::vector<double> chi2, redundancy;
  std::vector<char> stale;
  std::vector<int> stale_factors;
  // The same summed by the factor's newer endpoint.
  GrowingPrefixSums chi2_by_pose, redundancy_by_pose;
};

struct SparsePoseGraphSolver::Decompositions {
  internal::BlockSimplicialLLT simplicial;
};

SparsePoseGraphSolver::~SparsePoseGraphSolver() = default;
SparsePoseGraphSolver::SparsePoseGraphSolver(SparsePoseGraphSolver&&) noexcept = default;
SparsePoseGraphSolver& SparsePoseGraphSolver::operator=(SparsePoseGraphSolver&&) noexcept = default;

SparsePoseGraphSolver::SparsePoseGraphSolver(int dimension, double shape_c)
    : dimension_(dimension),
      tangent_(dimension == 2 ? 3 : 6),
      ambient_(dimension == 2 ? 3 : 7),
      shape_c_(shape_c),
      manifold_(makePoseManifold(dimension)),
      anchor_(toBlock(dimension, Pose::identity())),
      variance_terms_(std::make_unique<VarianceTerms>()),
      decompositions_(std::make_unique<Decompositions>()) {
  noise_scale_ = Eigen::VectorXd::Ones(tangent_);
  if (dimension != 2 && dimension != 3) throw std::invalid_argument("dimension must be 2 or 3");
}

int SparsePoseGraphSolver::addPose(const Pose& initial) {
  blocks_.push_back(toBlock(dimension_, initial));
  incident_.emplace_back();
  priors_.emplace_back();
  variance_terms_->chi2_by_pose.append();
  variance_terms_->redundancy_by_pose.append();
  return numPoses() - 1;
}

int SparsePoseGraphSolver::addFactor(int a, int b, const Pose& z,
                                     const Eigen::MatrixXd& information, FactorMode mode) {
  auto valid = [this](int id) { return id == kAnchor || (id >= 0 && id < numPoses()); };
  if (!valid(a) || !valid(b) || b == kAnchor || a == b)
    throw std::invalid_argument("factor refers to an unknown pose");
  Factor f{a, b, std::unique_ptr<ceres::CostFunction>(makePoseErrorCost(dimension_, z, information)),
           SigLoss(0.0, shape_c_), mode};
  factors_.push_back(std::move(f));
  sqrt_information_.push_back(sqrtInformation(information));
  if (noise_scaled_) rescale_.push_back(rescaleOf(sqrt_information_.back()));
  const int k = numFactors() - 1;
  if (a != kAnchor) {
    incident_[a].push_back(k);
    incident_[b].push_back(k);
  } else {
    priors_[b].push_back(k);
  }
  VarianceTerms& terms = *variance_terms_;
  terms.chi2.push_back(0.0);
  terms.redundancy.push_back(0.0);
  terms.stale.push_back(0);
  markStale(k);
  return k;
}

void SparsePoseGraphSolver::markStale(int factor) const {
  VarianceTerms& terms = *variance_terms_;
  if (terms.stale[factor]) return;
  terms.stale[factor] = 1;
  terms.stale_factors.push_back(factor);
}

void SparsePoseGraphSolver::poseMoved(int id) const {
  for (int k : incident_[id]) markStale(k);
  for (int k : priors_[id]) markStale(k);
}

void SparsePoseGraphSolver::evaluate(const Factor& f, double* residual, double* jac_a,
                                     double* jac_b) const {
  const double* parameters[2] = {blockOf(f.a), blockOf(f.b)};
  double ambient_a[6 * 7], ambient_b[6 * 7];
  double* jacobians[2] = {jac_a ? ambient_a : nullptr, jac_b ? ambient_b : nullptr};
  const bool want_jacobians = jac_a || jac_b;
  f.cost->Evaluate(parameters, residual, want_jacobians ? jacobians : nullptr);
  const Eigen::MatrixXd* rescale = noise_scaled_ ? &rescale_[&f - factors_.data()] : nullptr;
  if (rescale) applyRescale(*rescale, residual, 1);
  if (!want_jacobians) return;
  // Ambient -> tangent: J_local = J_ambient * PlusJacobian(x).
  double plus[7 * 6];
  auto to_local = [&](const double* x, const double* ambient, double* local) {
    if (dimension_ == 2) {
      std::copy(ambient, ambient + 9, local);
      return;
    }
    manifold_->PlusJacobian(x, plus);
    Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> out(local);
    out = Eigen::Map<const Eigen::Matrix<double, 6, 7, Eigen::RowMajor>>(ambient) *
          Eigen::Map<const Eigen::Matrix<double, 7, 6, Eigen::RowMajor>>(plus);
  };
  if (jac_a) to_local(parameters[0], ambient_a, jac_a);
  if (jac_b) to_local(parameters[1], ambient_b, jac_b);
  if (!rescale) return;
  for (double* jacobian : {jac_a, jac_b})
    if (jacobian) applyRescale(*rescale, jacobian, tangent_);
}

void SparsePoseGraphSolver::applyRescale(const Eigen::MatrixXd& rescale, double* rows, int columns) const {
  // In place and in fixed-size arithmetic: evaluate() runs for every factor
  // of every iteration, and a dynamic-size product allocates its temporary.
  auto apply = [&](auto size) {
    constexpr int D = decltype(size)::value;
    const Eigen::Map<const Eigen::Matrix<double, D, D>> m(rescale.data());
    if (columns == 1) {
      Eigen::Map<Eigen::Matrix<double, D, 1>> r(rows);
      const Eigen::Matrix<double, D, 1> scaled = m * r;
      r = scaled;
    } else {
      Eigen::Map<Eigen::Matrix<double, D, D, Eigen::RowMajor>> j(rows);
      const Eigen::Matrix<double, D, D, Eigen::RowMajor> scaled = m * j;
      j = scaled;
    }
  };
  if (tangent_ == 3) apply(std::integral_constant<int, 3>());
  else apply(std::integral_constant<int, 6>());
}

Eigen::MatrixXd SparsePoseGraphSolver::rescaleOf(const Eigen::MatrixXd& sqrt_information) const {
  // S D^-1 S^-1 = (S^-T D^-1 S^T)^T: one triangular solve.
  const Eigen::MatrixXd inverse_d = noise_scale_.cwiseSqrt().cwiseInverse().asDiagonal();
  const Eigen::MatrixXd st = sqrt_information.transpose();
  return sqrt_information.transpose().triangularView<Eigen::Lower>().solve(inverse_d * st).transpose();
}

void SparsePoseGraphSolver::setNoiseScale(const Eigen::VectorXd& scale) {
  if (scale.size() != tangent_ || !scale.allFinite() || (scale.array() < 1.0).any())
    throw std::invalid_argument("noise scale: one finite value >= 1 per tangent component");
  noise_scale_ = scale;
  noise_scaled_ = (scale.array() != 1.0).any();
  rescale_.clear();
  for (int factor = 0; factor < numFactors(); ++factor) {
    if (noise_scaled_) rescale_.push_back(rescaleOf(sqrt_information_[factor]));
    markStale(factor);
  }
  model_known_ = false;
}

double SparsePoseGraphSolver::factorCost(const Factor& f, const double* residual) const {
  if (f.mode == FactorMode::kDisabled) return 0.0;
  const double s = Eigen::Map<const Eigen::VectorXd>(residual, tangent_).squaredNorm();
  if (!kernelWeighted(f)) return 0.5 * s;
  double rho[3];
  f.loss.Evaluate(s, rho);
  return 0.5 * rho[0];
}

double SparsePoseGraphSolver::whitenedNorm(int factor) const {
  double residual[6];
  evaluate(factors_[factor], residual, nullptr, nullptr);
  return Eigen::Map<const Eigen::VectorXd>(residual, tangent_).norm();
}

double SparsePoseGraphSolver::weight(int factor) const {
  const Factor& f = factors_[factor];
  if (f.mode == FactorMode::kDisabled) return 0.0;
  if (!kernelWeighted(f)) return 1.0;
  return f.loss.weight(whitenedNorm(factor));
}

double SparsePoseGraphSolver::totalCost() const {
  double cost = 0.0, residual[6];
  for (const Factor& f : factors_) {
    evaluate(f, residual, nullptr, nullptr);
    cost += factorCost(f, residual);
  }
  return cost;
}

double SparsePoseGraphSolver::objective(int first_variable) const {
  const SigLoss graduated(1.0, shape_c_);
  double cost = 0.0, residual[6];
  for (const Factor& f : factors_) {
    if (f.mode == FactorMode::kDisabled || std::max(f.a, f.b) < first_variable) continue;
    evaluate(f, residual, nullptr, nullptr);
    const double r = Eigen::Map<const Eigen::VectorXd>(residual, tangent_).norm();
    cost += f.mode == FactorMode::kPlain ? 0.5 * r * r : graduated.rho(r);
  }
  return cost;
}

double SparsePoseGraphSolver::windowCost() const {
  double cost = 0.0, residual[6];
  for (const FactorSlot& slot : slots_) {
    const Factor& f = factors_[slot.factor];
    if (f.mode == FactorMode::kDisabled) continue;
    evaluate(f, residual, nullptr, nullptr);
    cost += factorCost(f, residual);
  }
  return cost;
}

void SparsePoseGraphSolver::buildStructure(int first) {
  const int nv = numPoses() - first;
  collectSlots(first);
  orderVariables(nv);
  const internal::BlockPattern pattern = upperBlockPattern(nv);
  allocateHessian(pattern);
  gradient_.resize(static_cast<long>(nv) * tangent_);
  factor_valid_ = false;
  model_known_ = false;
  decompositions_->simplicial.analyzeBlocks(pattern, tangent_);
  structure_first_ = first;
  structure_poses_ = numPoses();
  structure_factors_ = numFactors();
  built_version_ = structure_version_;
}

void SparsePoseGraphSolver::collectSlots(int first) {
  // The factors that touch a variable (pose >= first), their endpoints as
  // variables (pose - first) until orderVariables() maps them to rows.
  // Found through the variables' own factors (each at its newer endpoint),
  // so that a window costs what it holds, not the map; in factor order, so
  // that the normal equations are summed as they always were.
  window_factors_.clear();
  for (int id = std::max(first, 0); id < numPoses(); ++id) {
    for (int k : incident_[id])
      if (std::max(factors_[k].a, factors_[k].b) == id) window_factors_.push_back(k);
    window_factors_.insert(window_factors_.end(), priors_[id].begin(), priors_[id].end());
  }
  std::sort(window_factors_.begin(), window_factors_.end());
  auto var = [first](int id) { return id >= first ? id - first : -1; };
  slots_.clear();
  for (int k : window_factors_) {
    const Factor& f = factors_[k];
    if (f.mode == FactorMode::kDisabled || f.dormant) continue;
    const int va = f.a == kAnchor ? -1 : var(f.a);
    const int vb = var(f.b);  // va or vb is a variable: each factor found has an endpoint >= first
    slots_.push_back(FactorSlot{k, va, vb, va >= 0 && vb >= 0, 0, 0, 0, 0, -1, 0});
  }
}

namespace {

// The pattern of a symmetric block matrix from its coupled pairs (a, b),
// per column the sorted rows, the diagonal included: both triangles when
// `full`, else the upper one (rows <= column).
internal::BlockPattern blockPattern(int nv, const std::vector<std::pair<int, int>>& pairs, bool full) {
  internal::BlockPattern p;
  p.start.assign(nv + 1, 0);
  for (int j = 0; j < nv; ++j) ++p.start[j + 1];  // the diagonal
  for (const auto& [a, b] : pairs) {
    ++p.start[std::max(a, b) + 1];
    if (full) ++p.start[std::min(a, b) + 1];
  }
  for (int j = 0; j < nv; ++j) p.start[j + 1] += p.start[j];
  p.rows.resize(p.start[nv]);
  std::vector<int> next(p.start.begin(), p.start.end() - 1);
  for (int j = 0; j < nv; ++j) p.rows[next[j]++] = j;
  for (const auto& [a, b] : pairs) {
    p.rows[next[std::max(a, b)]++] = std::min(a, b);
    if (full) p.rows[next[std::min(a, b)]++] = std::max(a, b);
  }
  // Sorted and without the duplicates of parallel factors, compacted.
  int out = 0;
  for (int j = 0; j < nv; ++j) {
    const auto begin = p.rows.begin() + p.start[j], end = p.rows.begin() + p.start[j + 1];
    std::sort(begin, end);
    const auto last = std::unique(begin, end);
    p.start[j] = out;
    out = static_cast<int>(std::copy(begin, last, p.rows.begin() + out) - p.rows.begin());
  }
  p.start[nv] = out;
  p.rows.resize(out);
  return p;
}

}  // namespace

void SparsePoseGraphSolver::orderVariables(int nv) {
  // Fill-reducing ordering of the block pattern by SuiteSparse's AMD
  // (Amestoy, Davis & Duff): position_[v] is the block row of variable v in
  // the permuted Hessian. Eigen's minimum_degree_ordering (CSparse's
  // simpler AMD) left more fill on the same block graphs: the factor of the
  // whole of Sphere2500 cost 2.65e6 block flops (sum of squared column
  // counts) against 1.81e6, a 5 000-pose 3-D grid 1.71e6 against 1.55e6,
  // M3500 2.70e5 against 2.55e5.
  position_.resize(nv);
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(slots_.size());
  for (const FactorSlot& s : slots_)
    if (s.coupled) pairs.emplace_back(s.ia, s.ib);
  // Both triangles, sorted and without duplicates: what amd_order reads
  // fastest (it skips the diagonal).
  const internal::BlockPattern symmetric = blockPattern(nv, pairs, true);
  std::vector<int> order(nv);
  const int status = amd_order(nv, symmetric.start.data(), symmetric.rows.data(), order.data(), nullptr, nullptr);
  if (status != AMD_OK) throw std::runtime_error("AMD ordering failed (status " + std::to_string(status) + ")");
  for (int k = 0; k < nv; ++k) position_[order[k]] = k;
  for (FactorSlot& s : slots_) {
    if (s.ia >= 0) s.ia = position_[s.ia];
    if (s.ib >= 0) s.ib = position_[s.ib];
  }
}

internal::BlockPattern SparsePoseGraphSolver::upperBlockPattern(int nv) const {
  // Block rows I <= J present in each block column J (the upper triangle,
  // which the simplicial Cholesky factorises in place, without a copy).
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(slots_.size());
  for (const FactorSlot& s : slots_)
    if (s.coupled) pairs.emplace_back(s.ia, s.ib);
  return blockPattern(nv, pairs, false);
}

void SparsePoseGraphSolver::allocateHessian(const internal::BlockPattern& pattern) {
  // Dense d x d blocks, column-major within each block column, and where
  // each slot's blocks live in it.
  const int d = tangent_;
  const int nv = pattern.columns();
  const auto height = [&](int j) { return static_cast<long>(pattern.start[j + 1] - pattern.start[j]) * d; };
  std::vector<long> column_start(nv + 1, 0);
  for (int j = 0; j < nv; ++j) column_start[j + 1] = column_start[j] + height(j) * d;

  const long n = static_cast<long>(nv) * d;
  hessian_ = Eigen::SparseMatrix<double>(n, n);
  hessian_.resizeNonZeros(column_start[nv]);
  int* outer = hessian_.outerIndexPtr();
  int* inner = hessian_.innerIndexPtr();
  for (int j = 0; j < nv; ++j) {
    for (int c = 0; c < d; ++c) {
      const long start = column_start[j] + c * height(j);
      outer[j * d + c] = static_cast<int>(start);
      long k = start;
      for (int p = pattern.start[j]; p < pattern.start[j + 1]; ++p)
        for (int r = 0; r < d; ++r) inner[k++] = pattern.rows[p] * d + r;
    }
  }
  outer[n] = static_cast<int>(column_start[nv]);

  // Offset of block (i, j), i <= j: base + c * stride + r for entry (r, c).
  auto locate = [&](int i, int j, long* base, long* stride) {
    const auto first = pattern.rows.begin() + pattern.start[j], last = pattern.rows.begin() + pattern.start[j + 1];
    *stride = height(j);
    *base = column_start[j] + static_cast<long>(std::lower_bound(first, last, i) - first) * d;
  };
  for (FactorSlot& s : slots_) {
    if (s.ia >= 0) locate(s.ia, s.ia, &s.base_aa, &s.stride_aa);
    if (s.ib >= 0) locate(s.ib, s.ib, &s.base_bb, &s.stride_bb);
    if (s.coupled) locate(std::min(s.ia, s.ib), std::max(s.ia, s.ib), &s.base_ab, &s.stride_ab);
  }
}

template <int D>
double SparsePoseGraphSolver::linearize() {
  using Jacobian = Eigen::Matrix<double, D, D, Eigen::RowMajor>;
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;
  double* values = hessian_.valuePtr();
  std::fill(values, values + hessian_.nonZeros(), 0.0);
  gradient_.setZero();
  auto add_block = [values](long base, long stride, const Block& block) {
    for (int c = 0; c < D; ++c)
      for (int r = 0; r < D; ++r) values[base + c * stride + r] += block(r, c);
  };

  // H += w J^T J, g += w J^T r (IRLS weights of the SIG loss).
  double cost = 0.0;
  Vector r;
  Jacobian ja, jb;
  for (const FactorSlot& s : slots_) {
    const Factor& f = factors_[s.factor];
    if (f.mode == FactorMode::kDisabled || f.excluded) continue;
    evaluate(f, r.data(), s.ia >= 0 ? ja.data() : nullptr, s.ib >= 0 ? jb.data() : nullptr);
    double w = 1.0;
    if (kernelWeighted(f)) {
      double rho[3];
      f.loss.Evaluate(r.squaredNorm(), rho);
      w = rho[1];
      cost += 0.5 * rho[0];
    } else {
      cost += 0.5 * r.squaredNorm();
    }
    if (s.ia >= 0) {
      const Block wja = w * ja.transpose();
      add_block(s.base_aa, s.stride_aa, wja * ja);
      gradient_.template segment<D>(s.ia * D) += wja * r;
      if (s.coupled) {
        // Block (min, max) of the upper triangle: J_min^T J_max.
        if (s.ia < s.ib) add_block(s.base_ab, s.stride_ab, wja * jb);
        else add_block(s.base_ab, s.stride_ab, w * jb.transpose() * ja);
      }
    }
    if (s.ib >= 0) {
      const Block wjb = w * jb.transpose();
      add_block(s.base_bb, s.stride_bb, wjb * jb);
      gradient_.template segment<D>(s.ib * D) += wjb * r;
    }
  }
  return cost;
}

void SparsePoseGraphSolver::prepare(int first) {
  if (first != structure_first_ || numPoses() != structure_poses_ ||
      numFactors() != structure_factors_ || structure_version_ != built_version_)
    buildStructure(first);
}

bool SparsePoseGraphSolver::factorize() {
  const double h_flops = 4.0 * static_cast<double>(hessian_.nonZeros());  // symmetric product, upper stored
  ++factorizations_;
  decompositions_->simplicial.factorizeBlocks(hessian_);
  factor_valid_ = decompositions_->simplicial.info() == Eigen::Success;
  if (factor_valid_) {
    // Cholesky costs the sum over L's columns of their squared lengths.
    const Eigen::SparseMatrix<double>& l = decompositions_->simplicial.matrixL().nestedExpression();
    factorization_flops_ = 0.0;
    for (long j = 0; j < l.outerSize(); ++j) {
      const double column = static_cast<double>(l.outerIndexPtr()[j + 1] - l.outerIndexPtr()[j]);
      factorization_flops_ += column * column;
    }
    iteration_flops_ = 4.0 * static_cast<double>(l.nonZeros()) + h_flops;
  }
  return factor_valid_;
}

Eigen::VectorXd SparsePoseGraphSolver::gaussNewtonStep(double* residual) {
  const Eigen::VectorXd b = -gradient_;
  Eigen::VectorXd step;
  if (factor_valid_ && solveWithLastFactor(b, &step, residual)) return step;
  *residual = 0.0;
  if (!factorize()) return Eigen::VectorXd();
  return solve(b);
}

bool SparsePoseGraphSolver::solveWithLastFactor(const Eigen::VectorXd& b, Eigen::VectorXd* x, double* residual_out) {
  // Worth trying only if CG can succeed for less than a factorisation:
  // after the first solve and its residual, a change of one loop
  // closure's weight (rank d) takes d + 1 iterations in exact arithmetic.
  if ((3.0 + tangent_) * iteration_flops_ >= factorization_flops_) return false;
  const auto h = hessian_.selfadjointView<Eigen::Upper>();
  const double b_norm = b.norm();
  *residual_out = 0.0;
  if (!(b_norm > 0.0)) {  // at a stationary point the step is zero
    *x = Eigen::VectorXd::Zero(b.size());
    return true;
  }
  const double tolerance = kStepTolerance * b_norm;  // what the budget aims at
  *x = solve(b);
  Eigen::VectorXd r = b - h * *x;
  double spent = 2.0 * iteration_flops_;  // the first solve and residual
  if (!x->allFinite()) return false;
  *residual_out = r.norm() / b_norm;
  if (solvedEnough(*x, r.norm() / b_norm)) return true;
  const double first_residual = r.norm();
  Eigen::VectorXd z = solve(r);
  Eigen::VectorXd p = z;
  double rz = r.dot(z);
  for (int iteration = 1;; ++iteration) {
    spent += iteration_flops_;
    const Eigen::VectorXd hp = h * p;
    const double curvature = p.dot(hp);
    if (!(curvature > 0.0) || !(rz > 0.0)) return false;  // H not positive definite along p
    const double alpha = rz / curvature;
    *x += alpha * p;
    r -= alpha * hp;
    const double residual = r.norm();
    *residual_out = residual / b_norm;
    if (solvedEnough(*x, residual / b_norm)) return x->allFinite();
    // At the rate the residual has fallen so far, CG must reach the
    // tolerance before it has cost a new factorisation.
    const double rate = std::pow(residual / first_residual, 1.0 / iteration);
    if (!(rate < 1.0)) return false;
    const double needed = std::log(tolerance / residual) / std::log(rate);
    if (spent + needed * iteration_flops_ >= factorization_flops_) return false;
    z = solve(r);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
}

bool SparsePoseGraphSolver::solvedEnough(const Eigen::VectorXd& x, double relative) const {
  if (relative <= kStepTolerance) return true;
  if (!(relative <= forcing_)) return false;
  const long blocks = x.size() / tangent_;
  double sum = 0.0;
  for (long v = 0; v < blocks; ++v) sum += x.segment(v * tangent_, tangent_).norm();
  return sum / static_cast<double>(blocks) >= convergence_step_;
}

void SparsePoseGraphSolver::chooseForcingTerm(double gradient_norm) {
  const double previous = forcing_;
  forcing_ = kStepTolerance;
  const bool known = model_known_;
  model_known_ = false;  // until this iteration takes a step
  if (!known || !(last_gradient_norm_ > 0.0)) return;
  double eta = std::abs(gradient_norm - model_gradient_norm_) / last_gradient_norm_;
  const double floor = std::pow(previous, kForcingPower);
  if (floor > kForcingSafeguard) eta = std::max(eta, floor);
  if (std::isfinite(eta)) forcing_ = std::min(kMaxForcing, std::max(kStepTolerance, eta));
}

void SparsePoseGraphSolver::rememberModel(double gradient_norm, const Eigen::VectorXd& h_step) {
  model_known_ = true;
  last_gradient_norm_ = gradient_norm;
  model_gradient_norm_ = (gradient_ + h_step).norm();
}

Eigen::MatrixXd SparsePoseGraphSolver::solve(const Eigen::MatrixXd& rhs) {
  return decompositions_->simplicial.solve(rhs);
}

std::vector<SparsePoseGraphSolver::Prediction> SparsePoseGraphSolver::predict(const std::vector<int>& factors,
                                                                               int first,
                                                                               const std::vector<int>& without) {
  const int d = tangent_;
  std::vector<Prediction> out(factors.size());
  for (size_t i = 0; i < factors.size(); ++i) {
    out[i].residual.resize(d);
    evaluate(factors_[factors[i]], out[i].residual.data(), nullptr, nullptr);
    // Nothing free: nothing but the factor's own noise explains it.
    out[i].covariance = Eigen::MatrixXd::Identity(d, d);
  }
  first = std::max(0, std::min(first, numPoses()));
  if (numPoses() == first || factors.empty()) return out;
  prepare(first);
  for (int k : factors) factors_[k].excluded = true;
  for (int k : without) factors_[k].excluded = true;
  if (d == 3) linearize<3>();
  else linearize<6>();
  std::vector<int> left_out = factors;
  left_out.insert(left_out.end(), without.begin(), without.end());
  const double variance_factor = varianceFactor(first, left_out);
  for (int k : factors) factors_[k].excluded = false;
  for (int k : without) factors_[k].excluded = false;
  const bool factorized = factorize();

  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const long n = static_cast<long>(numPoses() - first) * d;
  double jac_a[36], jac_b[36];
  for (size_t i = 0; i < factors.size(); ++i) {
    const Factor& f = factors_[factors[i]];
    const int va = f.a == kAnchor || f.a < first ? -1 : position_[f.a - first];
    const int vb = f.b < first ? -1 : position_[f.b - first];
    if (va < 0 && vb < 0) continue;
    if (!factorized) {
      // A singular window (a free pose nothing holds) predicts nothing.
      out[i].covariance = Eigen::MatrixXd::Constant(d, d, std::numeric_limits<double>::infinity());
      continue;
    }
    evaluate(f, out[i].residual.data(), jac_a, jac_b);
    // J^T as n x d: the factor's whitened Jacobian rows, in window columns.
    Eigen::MatrixXd jt = Eigen::MatrixXd::Zero(n, d);
    if (va >= 0) jt.block(static_cast<long>(va) * d, 0, d, d) = Eigen::Map<const RowMajor>(jac_a, d, d).transpose();
    if (vb >= 0) jt.block(static_cast<long>(vb) * d, 0, d, d) = Eigen::Map<const RowMajor>(jac_b, d, d).transpose();
    const Eigen::MatrixXd spread = relativeCovariance(jt, std::min(va < 0 ? vb : va, vb < 0 ? va : vb) * d);
    if (spread.allFinite()) out[i].covariance = variance_factor * (out[i].covariance + spread);
    else out[i].covariance = Eigen::MatrixXd::Constant(d, d, std::numeric_limits<double>::infinity());
  }
  return out;
}

SparsePoseGraphSolver::Prediction SparsePoseGraphSolver::predictAlongPath(int factor, const std::vector<int>& path,
                                                                          double variance_factor) const {
  return tangent_ == 3 ? predictAlongPathOf<3>(factor, path, variance_factor)
                       : predictAlongPathOf<6>(factor, path, variance_factor);
}

template <int D>
SparsePoseGraphSolver::Prediction SparsePoseGraphSolver::predictAlongPathOf(int factor, const std::vector<int>& path,
                                                                            double variance_factor) const {
  using Block = Eigen::Matrix<double, D, D>;
  using RowMajor = Eigen::Matrix<double, D, D, Eigen::RowMajor>;
  const Factor& f = factors_[factor];
  Prediction out;
  out.residual.resize(D);
  out.covariance = Eigen::MatrixXd::Constant(D, D, std::numeric_limits<double>::infinity());
  double jac_a[36], jac_b[36];
  evaluate(f, out.residual.data(), jac_a, jac_b);
  if (f.a == kAnchor) return out;
  const int older = std::min(f.a, f.b), newer = std::max(f.a, f.b);
  // Linearised, a factor of weight w from pose p to the next pose q of the
  // path says sqrt(w) (J_p dp + J_q dq) = n with n ~ N(0, I), so
  // dq = T dp + J_q^-1 n / sqrt(w) with T = -J_q^-1 J_p, and the
  // covariance of dq given dp's is T Sigma_p T^T + J_q^-1 J_q^-T / w.
  Block sigma = Block::Zero();
  int at = older;
  double residual[6], jac_p[36], jac_q[36];
  for (int k : path) {
    const Factor& step = factors_[k];
    const bool forward = step.a == at;
    if (step.a == kAnchor || step.dormant || (!forward && step.b != at)) return out;
    evaluate(step, residual, forward ? jac_p : jac_q, forward ? jac_q : jac_p);
    double w = step.mode == FactorMode::kDisabled ? 0.0 : 1.0;
    if (kernelWeighted(step)) {
      double rho[3];
      step.loss.Evaluate(Eigen::Map<const Eigen::Matrix<double, D, 1>>(residual).squaredNorm(), rho);
      w = rho[1];
    }
    if (!(w > 0.0)) return out;
    const Block j_q_inverse = Eigen::Map<const RowMajor>(jac_q).inverse();
    const Block t = -j_q_inverse * Eigen::Map<const RowMajor>(jac_p);
    sigma = t * sigma * t.transpose() + (j_q_inverse * j_q_inverse.transpose()) / w;
    at = forward ? step.b : step.a;
  }
  if (at != newer || !sigma.allFinite()) return out;
  const Eigen::Map<const RowMajor> j_newer(f.b == newer ? jac_b : jac_a);
  out.covariance = variance_factor * (Block::Identity() + j_newer * sigma * j_newer.transpose());
  return out;
}

std::vector<int> SparsePoseGraphSolver::shortestPath(int from, int to, const std::vector<int>& without) const {
  PathSearch search = pathSearch(without);
  return findShortestPath(&search, from, to);
}

SparsePoseGraphSolver::PathSearch SparsePoseGraphSolver::pathSearch(const std::vector<int>& without) const {
  PathSearch search;
  // Lengths are found as searches reach the factors: a search from a
  // near endpoint touches a small part of the map.
  search.factor_length.assign(factors_.size(), std::numeric_limits<double>::quiet_NaN());
  for (int k : without) search.factor_length[k] = std::numeric_limits<double>::infinity();
  search.reached.assign(blocks_.size(), std::numeric_limits<double>::infinity());
  search.via.assign(blocks_.size(), -1);
  search.visit.assign(blocks_.size(), 0);
  search.done.assign(blocks_.size(), 0);
  // Lengths are found lazily, so the span bound takes every factor a path
  // may cross: weights are at most 1, so a factor counts at least 1 and no
  // step of a path covers more than longest_span per unit of length.
  for (size_t k = 0; k < factors_.size(); ++k) {
    const Factor& f = factors_[k];
    if (f.a == kAnchor || f.dormant || f.mode == FactorMode::kDisabled || std::isinf(search.factor_length[k])) continue;
    search.longest_span = std::max(search.longest_span, positionDistance(f.a, f.b));
  }
  return search;
}

double SparsePoseGraphSolver::positionDistance(int a, int b) const {
  const int n = dimension_;  // the position comes first in a block
  double squared = 0.0;
  for (int i = 0; i < n; ++i) squared += (blocks_[a][i] - blocks_[b][i]) * (blocks_[a][i] - blocks_[b][i]);
  return std::sqrt(squared);
}

std::vector<int> SparsePoseGraphSolver::findShortestPath(PathSearch* search, int from, int to) const {
  const unsigned id = runSearch(search, from, to);
  std::vector<int> path;
  if (search->visit[to] != id) return path;
  for (int p = to; p != from;) {
    const Factor& f = factors_[search->via[p]];
    path.push_back(search->via[p]);
    p = f.a == p ? f.b : f.a;
  }
  std::reverse(path.begin(), path.end());
  return path;
}

SparsePoseGraphSolver::PathTree SparsePoseGraphSolver::pathTree(PathSearch* search, int root) const {
  const unsigned id = runSearch(search, root, -1);
  PathTree tree;
  tree.root = root;
  tree.toward_root.assign(blocks_.size(), -1);
  for (int p = 0; p < numPoses(); ++p)
    if (search->visit[p] == id && p != root) tree.toward_root[p] = search->via[p];
  return tree;
}

std::vector<int> SparsePoseGraphSolver::pathToRoot(const PathTree& tree, int from) const {
  std::vector<int> path;
  if (from >= static_cast<int>(tree.toward_root.size())) return path;
  for (int p = from; tree.toward_root[p] >= 0;) {
    const Factor& f = factors_[tree.toward_root[p]];
    path.push_back(tree.toward_root[p]);
    p = f.a == p ? f.b : f.a;
  }
  return path;
}

unsigned SparsePoseGraphSolver::runSearch(PathSearch* search, int from, int to) const {
  // A* from `from`, stopping at `to` (see shortestPath). Poses added after
  // pathSearch() join through factors that were not there when the span
  // bound was taken: those may exceed it, so the search is then Dijkstra's.
  const bool bounded = to >= 0 && search->longest_span > 0.0 && search->factor_length.size() == factors_.size();
  const int poses = numPoses();
  if (static_cast<int>(search->reached.size()) < poses) {
    search->reached.resize(poses);
    search->via.resize(poses);
    search->visit.resize(poses, 0);
    search->done.resize(poses, 0);
  }
  if (search->factor_length.size() < factors_.size())
    search->factor_length.resize(factors_.size(), std::numeric_limits<double>::quiet_NaN());
  const unsigned id = ++search->search;
  auto reached = [&](int p) {
    return search->visit[p] == id ? search->reached[p] : std::numeric_limits<double>::infinity();
  };
  auto length_of = [&](int k) {
    double& length = search->factor_length[k];
    if (std::isnan(length)) {
      const Factor& f = factors_[k];
      const double w = f.dormant || f.mode == FactorMode::kDisabled ? 0.0 : weight(k);
      length = w > 0.0 ? 1.0 / w : std::numeric_limits<double>::infinity();
    }
    return length;
  };
  const double inverse_span = bounded ? 1.0 / search->longest_span : 0.0;
  auto remaining = [&](int p) { return bounded ? inverse_span * positionDistance(p, to) : 0.0; };
  using Entry = std::pair<double, int>;  // reached + remaining, pose
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  search->visit[from] = id;
  search->reached[from] = 0.0;
  queue.push({remaining(from), from});
  while (!queue.empty()) {
    const int p = queue.top().second;
    queue.pop();
    if (p == to) break;
    if (search->done[p] == id) continue;  // reached again on a shorter path, expanded then
    search->done[p] = id;
    const double l = reached(p);
    for (int k : incident_[p]) {
      const int q = factors_[k].a == p ? factors_[k].b : factors_[k].a;
      if (l + 1.0 >= reached(q)) continue;  // no factor counts less than 1
      const double length = l + length_of(k);
      if (!(length < reached(q))) continue;
      search->visit[q] = id;
      search->reached[q] = length;
      search->via[q] = k;
      queue.push({length + remaining(q), q});
    }
  }
  return id;
}

Eigen::MatrixXd SparsePoseGraphSolver::relativeCovariance(const Eigen::MatrixXd& jt, long first_row) {
  // J H^-1 J^T = (L^-1 J^T)^T (L^-1 J^T), H = L L^T. J^T is zero above
  // first_row, and so is L^-1 J^T; below, only the columns of L that the
  // forward substitution reaches from there (the elimination tree's paths
  // to its root) change it, a small part of L for a factor with two
  // endpoints -- where a full solve would go through all of L twice.
  const Eigen::SparseMatrix<double>& l = decompositions_->simplicial.matrixL().nestedExpression();
  Eigen::MatrixXd x = jt;
  const long n = x.rows();
  for (long j = first_row; j < n; ++j) {
    if (x.row(j).isZero(0.0)) continue;
    Eigen::SparseMatrix<double>::InnerIterator it(l, j);  // the diagonal comes first
    x.row(j) /= it.value();
    for (++it; it; ++it) x.row(it.row()) -= it.value() * x.row(j);
  }
  return x.transpose() * x;
}

double SparsePoseGraphSolver::varianceFactor(int first_variable, const std::vector<int>& without) const {
  // Each robust factor adds its dimension to the redundancy, times its
  // kernel weight (a rejected one adds nothing); the stated covariances
  // count as a prior worth one factor, so a window without loop closures
  // keeps a factor of 1.
  refreshVarianceTerms();
  const VarianceTerms& terms = *variance_terms_;
  const size_t first = static_cast<size_t>(std::max(0, std::min(first_variable, numPoses())));
  const size_t poses = terms.chi2_by_pose.size();
  double chi2 = terms.chi2_by_pose.prefix(poses) - terms.chi2_by_pose.prefix(first);
  double redundancy = terms.redundancy_by_pose.prefix(poses) - terms.redundancy_by_pose.prefix(first);
  std::vector<int> left_out = without;
  std::sort(left_out.begin(), left_out.end());
  left_out.erase(std::unique(left_out.begin(), left_out.end()), left_out.end());
  for (int k : left_out) {
    if (std::max(factors_[k].a, factors_[k].b) < first_variable) continue;
    chi2 -= terms.chi2[k];
    redundancy -= terms.redundancy[k];
  }
  // The differences of sums may fall a rounding error below zero.
  const double dof = tangent_;
  return (dof + std::max(0.0, chi2)) / (dof + std::max(0.0, redundancy));
}

void SparsePoseGraphSolver::refreshVarianceTerms() const {
  VarianceTerms& terms = *variance_terms_;
  const double dof = tangent_;
  double residual[6];
  for (int k : terms.stale_factors) {
    terms.stale[k] = 0;
    const Factor& f = factors_[k];
    double chi2 = 0.0, redundancy = 0.0;
    if (f.mode != FactorMode::kDisabled && !f.dormant) {
      evaluate(f, residual, nullptr, nullptr);
      const double s = Eigen::Map<const Eigen::VectorXd>(residual, tangent_).squaredNorm();
      double w = 1.0;
      if (f.mode == FactorMode::kRobust) {
        if (kernelWeighted(f)) {
          double rho[3];
          f.loss.Evaluate(s, rho);
          w = rho[1];
        }
        redundancy = w * dof;
      }
      chi2 = w * s;
    }
    const size_t newer = static_cast<size_t>(std::max(f.a, f.b));
    terms.chi2_by_pose.add(newer, chi2 - terms.chi2[k]);
    terms.redundancy_by_pose.add(newer, redundancy - terms.redundancy[k]);
    terms.chi2[k] = chi2;
    terms.redundancy[k] = redundancy;
  }
  terms.stale_factors.clear();
}

IterationResult SparsePoseGraphSolver::iterate(int first) {
  IterationResult result;
  first = std::max(0, std::min(first, numPoses()));
  const int nv = numPoses() - first;
  if (nv == 0) return result;
  prepare(first);

  const double cost = tangent_ == 3 ? linearize<3>() : linearize<6>();
  result.cost_before = cost;
  result.cost_after = cost;

  saved_.assign(blocks_.begin() + first, blocks_.end());
  const double gradient_norm = gradient_.norm();
  chooseForcingTerm(gradient_norm);
  Eigen::VectorXd gauss_newton = gaussNewtonStep(&result.solve_residual);
  if (gauss_newton.size() == 0 || !gauss_newton.allFinite()) {
    // Singular system: fall back to steepest descent inside the trust region.
    gauss_newton = Eigen::VectorXd::Constant(gradient_.size(), std::numeric_limits<double>::infinity());
    result.solve_residual = 1.0;
  }
  if (!trust_region_) {
    if (!gauss_newton.allFinite()) return result;
    const Eigen::VectorXd h_step = hessian_.selfadjointView<Eigen::Upper>() * gauss_newton;
    result.predicted_decrease = -(gradient_.dot(gauss_newton) + 0.5 * gauss_newton.dot(h_step));
    if (takeStep(first, gauss_newton, cost, &result)) rememberModel(gradient_norm, h_step);
    return result;
  }

  // Powell's dogleg inside a trust region (as iSAM2's Dogleg in riSAM): a
  // single GNC step at a small mu cannot fold the map towards a new outlier
  // before graduation rejects it. The radius is computed before the step is
  // taken, so `truncated` says whether this step was the full GN step.
  const Eigen::VectorXd hg = hessian_.selfadjointView<Eigen::Upper>() * gradient_;
  const double g2 = gradient_.squaredNorm();
  const double ghg = gradient_.dot(hg);
  const DoglegPath path{gauss_newton,
                        ghg > 0 ? Eigen::VectorXd(-(g2 / ghg) * gradient_) : Eigen::VectorXd(-gradient_)};
  // With step extension on, the radius only keeps the model honest: the
  // iteration starts from the full Gauss-Newton step, and a step the model
  // mispredicts shrinks it at the price of a cost evaluation (a damping
  // attempt) rather than of the factorisations that growing it from a
  // small radius takes (a drift correction: one per tripling).
  if (step_extension_ && std::isfinite(path.gaussNewtonNorm()))
    radius_ = std::max(radius_, std::min(max_radius_, path.gaussNewtonNorm()));
  for (int attempt = 0; attempt < kMaxDampingAttempts; ++attempt) {
    TrialStep trial = tryStep(first, path, radius_, cost, &result);
    const double step_norm = trial.step.norm();
    if (trial.meaningful && trial.ratio >= kGoodRatio)
      radius_ = std::min(max_radius_, std::max(radius_, kGrowth * step_norm));
    else if (trial.meaningful && trial.ratio < kPoorRatio)
      radius_ = std::max(kMinRadius, kShrink * std::min(radius_, step_norm));
    if (result.accepted) {
      if (step_extension_ && result.truncated && trial.meaningful && trial.ratio >= kGoodRatio)
        extendStep(first, path, cost, &trial, &result);
      rememberModel(gradient_norm, trial.h_step);
      return result;
    }
    if (!trial.meaningful) return result;  // converged: nothing left to gain
  }
  return result;
}

Eigen::VectorXd SparsePoseGraphSolver::DoglegPath::at(double radius) const {
  const double gn_norm = gaussNewtonNorm();
  if (gn_norm <= radius) return gauss_newton;
  const double sd_norm = steepest.norm();
  if (sd_norm >= radius || !gauss_newton.allFinite()) return (radius / sd_norm) * steepest;
  // The point on the segment steepest -> gauss_newton at distance radius.
  const Eigen::VectorXd d = gauss_newton - steepest;
  const double a = d.squaredNorm(), b = 2.0 * steepest.dot(d), c = steepest.squaredNorm() - radius * radius;
  const double tau = (-b + std::sqrt(std::max(0.0, b * b - 4.0 * a * c))) / (2.0 * a);
  return steepest + tau * d;
}

double SparsePoseGraphSolver::DoglegPath::gaussNewtonNorm() const {
  return gauss_newton.allFinite() ? gauss_newton.norm() : std::numeric_limits<double>::infinity();
}

SparsePoseGraphSolver::TrialStep SparsePoseGraphSolver::tryStep(int first, const DoglegPath& path, double radius,
                                                                double cost, IterationResult* result) {
  TrialStep trial;
  trial.step = path.at(radius);
  trial.h_step = hessian_.selfadjointView<Eigen::Upper>() * trial.step;
  const double predicted = -(gradient_.dot(trial.step) + 0.5 * trial.step.dot(trial.h_step));
  takeStep(first, trial.step, cost, result);
  result->predicted_decrease = predicted;
  result->truncated = !(path.gaussNewtonNorm() <= radius);
  // Near convergence both decreases are round-off; their ratio says nothing
  // about the model, so the radius is left alone there.
  trial.meaningful = meaningfulDecrease(predicted, cost);
  trial.ratio = predicted > 0 ? (cost - result->cost_after) / predicted : -1.0;
  return trial;
}

void SparsePoseGraphSolver::extendStep(int first, const DoglegPath& path, double cost, TrialStep* taken,
                                       IterationResult* result) {
  // radius_ has grown to kGrowth times the step just taken; try the longer
  // step of the same path, on the same linearisation, while it lowers the
  // cost further and the model still predicts the decrease.
  while (result->truncated && radius_ > taken->step.norm()) {
    IterationResult longer_result;
    longer_result.cost_before = result->cost_before;
    const TrialStep longer = tryStep(first, path, radius_, cost, &longer_result);
    const bool better = longer_result.accepted && longer_result.cost_after < result->cost_after;
    if (!better || longer.ratio < kGoodRatio) {
      if (longer.ratio < kPoorRatio) radius_ = std::max(taken->step.norm(), kShrink * longer.step.norm());
      IterationResult restored;
      takeStep(first, taken->step, cost, &restored);  // back to the last step the model predicted
      return;
    }
    *taken = longer;
    *result = longer_result;
    radius_ = std::min(max_radius_, std::max(radius_, kGrowth * longer.step.norm()));
  }
}

bool SparsePoseGraphSolver::takeStep(int first, const Eigen::VectorXd& delta, double cost,
                                     IterationResult* result) {
  result->cost_after = cost;
  if (!delta.allFinite()) return false;
  const int d = tangent_;
  const int nv = numPoses() - first;
  double step_sum = 0.0;
  for (int v = 0; v < nv; ++v) {
    const double* dv = delta.data() + static_cast<long>(position_[v]) * d;
    manifold_->Plus(saved_[v].data(), dv, blocks_[first + v].data());
    step_sum += Eigen::Map<const Eigen::VectorXd>(dv, d).norm();
  }
  const double new_cost = windowCost();
  if (new_cost <= cost + 1e-10 * std::abs(cost) + 1e-12) {
    for (const FactorSlot& slot : slots_) markStale(slot.factor);
    result->cost_after = new_cost;
    result->mean_step = step_sum / nv;
    result->accepted = true;
    return true;
  }
  std::copy(saved_.begin(), saved_.end(), blocks_.begin() + first);
  return false;
}

}  // namespace core
}  // namespace agnc_pgo
