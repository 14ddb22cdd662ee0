// A warm-started Gauss-Newton / dogleg solver for pose graphs.
//
// Why not ceres::Solve per GNC step: every Solve() call re-runs Ceres'
// preprocessing and a symbolic analysis over the whole graph, which dominates
// the cost of the one or two iterations a warm-started GNC step needs. Here
// the error terms are still Ceres cost functions and manifolds (evaluated
// through ceres::CostFunction::Evaluate), but the normal equations are
// assembled into a block pattern built once per structure and factorised
// numerically only.
//
// The pattern is ordered by AMD on the pose (block) graph, which is 9x (SE(2))
// to 36x (SE(3)) smaller than the scalar pattern, and assembled already
// permuted in upper-triangular form, so a simplicial Cholesky (Eigen's,
// on blocks) factorises it in place (natural ordering, no copy). In 2-D and
// in 3-D this beat CHOLMOD's supernodal factorisation over whole replays:
// CHOLMOD's per-call overhead dominated the windows. A whole SE(3) graph
// factorised from scratch costs more this way (Sphere2500: about 1.2x with
// SuiteSparse's AMD on the blocks, 1.7x with Eigen's; no BLAS-3 supernodes),
// but an incremental run rarely does that (doc/performance.md, "SE(3) on
// 6 x 6 blocks" and "SuiteSparse's AMD for the block order").
//
// A solve can be restricted to a window: poses with id >= first_variable are
// variables; older poses are held fixed and only factors touching a variable
// pose take part. Factors are robust (SIG loss with a mutable mu), plain, or
// disabled.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include <Eigen/SparseCore>
#include <ceres/cost_function.h>
#include <ceres/manifold.h>

#include "agnc_pgo/core/pose.h"
#include "agnc_pgo/core/pose_manifolds.h"
#include "agnc_pgo/core/sig_loss.h"

namespace agnc_pgo {
namespace core {
namespace internal {
struct BlockPattern;  // src/core/block_simplicial_llt.h
}  // namespace internal

enum class FactorMode { kRobust, kPlain, kDisabled };

struct IterationResult {
  double cost_before = 0;  // robust cost of the window's factors before the step
  double cost_after = 0;
  double mean_step = 0;    // mean tangent-step norm per variable pose
  // The decrease the Gauss-Newton model predicted for the step taken,
  // -(g.delta + delta' H delta / 2); its ratio to the actual decrease says
  // how well the model describes the cost there.
  double predicted_decrease = 0;
  // How exactly the Gauss-Newton step solved H delta = -g: |H delta + g| / |g|
  // (0 after a factorisation; CG stops within the forcing term).
  double solve_residual = 1.0;
  bool accepted = false;   // false: no step reduced the cost; the estimate is unchanged
  bool truncated = false;  // the step was cut short by the trust region (not a full Gauss-Newton step)
};

class SparsePoseGraphSolver {
 public:
  // Passed as a factor endpoint: a constant identity pose (for priors).
  static constexpr int kAnchor = -1;

  explicit SparsePoseGraphSolver(int dimension, double shape_c = 3.0);
  ~SparsePoseGraphSolver();
  SparsePoseGraphSolver(SparsePoseGraphSolver&&) noexcept;
  SparsePoseGraphSolver& operator=(SparsePoseGraphSolver&&) noexcept;

  // Whether a decrease the model predicts at this cost is more than
  // round-off; below it, the ratio of actual to predicted says nothing.
  static bool meaningfulDecrease(double predicted, double cost) {
    return predicted > 1e-10 * std::max(1.0, std::abs(cost));
  }

  int dimension() const { return dimension_; }
  int numPoses() const { return static_cast<int>(blocks_.size()); }
  int numFactors() const { return static_cast<int>(factors_.size()); }
  // Numeric factorisations so far (iterate() reuses the last one where it can).
  long factorizations() const { return factorizations_; }
  // The relative residual |H x + g| / |g| the last iteration's step had to
  // reach if conjugate gradients found it (see chooseForcingTerm).
  double forcingTerm() const { return forcing_; }

  int addPose(const Pose& initial);
  Pose pose(int id) const { return fromBlock(dimension_, blocks_[id]); }
  // Moving a pose from outside makes the next iteration solve exactly (see
  // chooseForcingTerm): the last step's model was of another point. A
  // changed mu does not: that its model mispredicts the new gradient is
  // what the forcing term measures.
  void setPose(int id, const Pose& pose) {
    blocks_[id] = toBlock(dimension_, pose);
    model_known_ = false;
    poseMoved(id);
  }
  // The estimate as the solver holds it (pose_manifolds.h), one block per pose.
  const std::vector<PoseBlock>& blocks() const { return blocks_; }

  // A factor on the pose of `b` relative to `a` (a may be kAnchor for a
  // prior: then z is the prior value). Throws std::invalid_argument on a
  // non-positive-definite information or unknown pose.
  int addFactor(int a, int b, const Pose& z, const Eigen::MatrixXd& information, FactorMode mode);

  void setMu(int factor, double mu) {
    factors_[factor].loss.setMu(mu);
    markStale(factor);
  }
  double mu(int factor) const { return factors_[factor].loss.mu(); }
  void setMode(int factor, FactorMode mode) {
    if ((factors_[factor].mode == FactorMode::kDisabled) != (mode == FactorMode::kDisabled))
      ++structure_version_;
    factors_[factor].mode = mode;
    markStale(factor);
  }
  // A dormant factor keeps its mode and mu but leaves the linear system (and
  // the window cost) until woken: a rejected loop closure whose kernel weight
  // is negligible would otherwise add fill-in for nothing -- a random
  // long-range outlier couples two distant parts of the graph.
  void setDormant(int factor, bool dormant) {
    if (factors_[factor].dormant != dormant) ++structure_version_;
    factors_[factor].dormant = dormant;
    markStale(factor);
  }
  // A robust factor at full weight enters the solve as a plain one (cost
  // r^2 / 2, weight 1) but keeps its mode and mu, and objective() still
  // prices it at mu = 1: the engine's loop closures whose graduation ended
  // inside the chi-square gate, so that the estimate is the least-squares
  // one over what the robust objective decided to keep.
  void setFullWeight(int factor, bool full_weight) {
    factors_[factor].full_weight = full_weight;
    markStale(factor);
  }
  // Every factor's stated covariance Sigma becomes D Sigma D, D = diag(sqrt(
  // scale)) per tangent component (translation first; each >= 1): the error
  // e is whitened with S D^-1 instead of S, so residuals and Jacobians are
  // multiplied by S D^-1 S^-1. Widens what the kernels and the tests on
  // whitened residuals take for noise (noise_scale.h); all ones undoes it.
  void setNoiseScale(const Eigen::VectorXd& scale);
  const Eigen::VectorXd& noiseScale() const { return noise_scale_; }
  bool noiseScaled() const { return noise_scaled_; }  // some component > 1

  // The whitened residual norm r = |S e| at the current estimate.
  double whitenedNorm(int factor) const;
  // The kernel weight at the factor's current mu (1 for plain, 0 disabled).
  double weight(int factor) const;

  // One iteration over the poses with id >= first_variable: the
  // Gauss-Newton step, or with a trust region Powell's dogleg step. A step
  // that does not reduce the robust cost is not taken.
  IterationResult iterate(int first_variable);

  // Dogleg trust region (persisting across iterations), radius in the
  // tangent-space norm of the whole step, at most max_radius. Off: plain
  // Gauss-Newton.
  void setTrustRegion(bool enabled, double initial_radius, double max_radius) {
    trust_region_ = enabled;
    initial_radius_ = initial_radius;
    max_radius_ = max_radius;
    resetTrustRegion();
  }
  // The caller's iterations end at a step whose mean norm per pose is below
  // `mean_step`: such a step is always solved exactly, so that convergence
  // is judged on the Gauss-Newton step itself (see chooseForcingTerm).
  // Infinite (the default): every step is exact.
  void setConvergenceStep(double mean_step) { convergence_step_ = mean_step; }
  // The next iteration starts again from the initial radius.
  void resetTrustRegion() { radius_ = initial_radius_; }
  // While on, the radius only has to keep the model honest: each iteration
  // starts from the full Gauss-Newton step (the radius is raised to it), a
  // step that raises the cost or that the model mispredicts (ratio below
  // the shrink bound) is shrunk at the price of a cost evaluation, and a
  // truncated step that the quadratic model predicted well is extended
  // along the same dogleg path, on the same factorisation, while the longer
  // step lowers the cost further and the model still predicts it (ratio >=
  // the radius' growth bound). Learning how far the model reaches by
  // growing a small radius, tripling it once per iteration, costs one
  // factorisation per tripling (a drift correction of hundreds of metres:
  // five of them). Off (the default), the radius also bounds how far one
  // iteration goes, which is what keeps a new outlier at a small mu from
  // pulling the map far.
  void setStepExtension(bool enabled) { step_extension_ = enabled; }

  // Robust cost over all factors (0.5 * sum rho).
  double totalCost() const;
  // The cost GNC minimises once every robust factor has graduated, over the
  // factors with an endpoint >= first_variable (those a window solve can
  // change): as totalCost(), but each robust factor at mu = 1
  // (Geman-McClure) whatever its current mu, and dormant ones included.
  double objective(int first_variable = 0) const;

  // What the rest of the window predicts for a factor: its whitened residual
  // r and the covariance S = s0^2 (I + J H^-1 J^T) of r, where J is its
  // whitened Jacobian and H the Gauss-Newton Hessian of the window (poses >=
  // first_variable free, older ones fixed) without the given factors.
  // J H^-1 J^T is the relative covariance of the factor's endpoints, whitened
  // by its information; r^T S^-1 r is, to first order, how much the window's
  // optimal cost rises when the factor is added (the data-association test
  // of iSAM and PCM). s0^2 is the window's a-posteriori variance of unit
  // weight (varianceFactor): graphs state their noise up to 40 times
  // the real variance (M3500), which would make the map look uncertain enough
  // to absorb anything. One factorisation for all the given factors.
  struct Prediction {
    Eigen::VectorXd residual;
    Eigen::MatrixXd covariance;
  };
  // `without`: further factors left out of H and of s0^2 (those judged
  // with these ones).
  std::vector<Prediction> predict(const std::vector<int>& factors, int first_variable,
                                  const std::vector<int>& without = {});
  // The covariance predict() would give the factor if only the factors of
  // `path` held its endpoints: a path from its older endpoint to its newer
  // one (shortestPath), the older endpoint fixed; times the given variance
  // factor, with the residual at the current estimate. Information only
  // tightens a covariance, so at the same estimate and variance factor
  // predict()'s covariance lies between variance_factor * I and this one,
  // found without a factorisation in time linear in the path. Infinite if
  // the path does not join the endpoints or holds a factor of no weight or
  // out of the linear system (dormant).
  Prediction predictAlongPath(int factor, const std::vector<int>& path, double variance_factor) const;
  // The factors of the path from pose `from` to pose `to` that crosses the
  // fewest full-weight factors (a factor of kernel weight w counts 1/w),
  // over the factors predict() linearises but `without`; empty if none.
  // Found by A*: no factor counts less than 1 nor spans more than the
  // longest factor a path may cross, so the straight-line distance to `to`
  // over that span never overestimates what is left of a path (a consistent
  // heuristic), and the search expands the poses between the endpoints
  // instead of every pose nearer to `from` than `to` is -- most of the map
  // for a far loop closure.
  std::vector<int> shortestPath(int from, int to, const std::vector<int>& without) const;
  // What many findShortestPath() searches at one estimate share: each factor's
  // length, found once, and scratch space reused between searches. Valid
  // while the estimate and the factors' modes, mu and dormancy stay as they
  // were when pathSearch() made it.
  struct PathSearch {
    std::vector<double> factor_length;  // 1/w, infinite where no path may pass; NaN: not found yet
    std::vector<double> reached;  // per pose, length of the shortest path found
    std::vector<int> via;         // per pose, the last factor of that path
    std::vector<unsigned> visit;  // per pose, the search that last reached it
    std::vector<unsigned> done;   // per pose, the search that last expanded it
    unsigned search = 0;
    // The longest distance between the endpoints of a factor a path may
    // cross, at this estimate (A*'s heuristic divides by it).
    double longest_span = 0.0;
  };
  PathSearch pathSearch(const std::vector<int>& without) const;
  std::vector<int> findShortestPath(PathSearch* search, int from, int to) const;
  // The shortest paths from every pose to one pose, the root (Dijkstra over
  // the whole map): per pose, the first factor of its path, -1 at the root
  // and where no path reaches. The paths stay paths when the map changes
  // (any path bounds the map's prediction, predictAlongPath); one that
  // crosses a factor since left out of the linear system predicts nothing.
  struct PathTree {
    int root = -1;
    std::vector<int> toward_root;
  };
  PathTree pathTree(PathSearch* search, int root) const;
  // The factors of the tree's path from `from` to its root, in that order;
  // empty if the tree does not reach `from` (or `from` is the root).
  std::vector<int> pathToRoot(const PathTree& tree, int from) const;
  // The a-posteriori variance of unit weight over the factors with an
  // endpoint >= first_variable but `without` (those being judged) and the
  // dormant ones, at the current estimate, as predict() uses for its
  // window (the same factors): sum of w r^2 over
  // sum of w dim for robust factors of kernel weight w, the stated
  // covariances counting as one more factor. Each factor's terms are kept
  // and summed by its newer endpoint, so that a query costs the factors
  // that changed since the last one (evaluated again then) and log(poses),
  // not an evaluation of the window: an arriving loop closure far back
  // would otherwise pay for most of the map.
  double varianceFactor(int first_variable, const std::vector<int>& without) const;

 private:
  struct Factor {
    int a, b;
    std::unique_ptr<ceres::CostFunction> cost;
    SigLoss loss;
    FactorMode mode;
    bool dormant = false;
    bool full_weight = false;  // setFullWeight
    bool excluded = false;  // left out of linearize() (predict()), structure unchanged
  };
  // Whether the factor enters the solve with its kernel's IRLS weight
  // (robust, not at full weight) rather than with weight 1.
  static bool kernelWeighted(const Factor& f) { return f.mode == FactorMode::kRobust && !f.full_weight; }
  // A factor's S D^-1 S^-1 for the current noise scale.
  Eigen::MatrixXd rescaleOf(const Eigen::MatrixXd& sqrt_information) const;
  // Where a window factor's blocks live in the sparse matrix.
  struct FactorSlot {
    int factor;
    int ia, ib;               // block row in the permuted Hessian, or -1 (fixed)
    bool coupled;             // has an off-diagonal block: both endpoints are variables
    long base_aa, stride_aa;  // (ia, ia)
    long base_bb, stride_bb;  // (ib, ib)
    long base_ab, stride_ab;  // (min, max) when coupled
  };

  void buildStructure(int first_variable);
  // buildStructure()'s steps: the window's factors (slots_), their block
  // order (position_), the upper block pattern per block column, and the
  // Hessian's storage with each slot's offsets in it.
  void collectSlots(int first_variable);
  void orderVariables(int variables);
  internal::BlockPattern upperBlockPattern(int variables) const;
  void allocateHessian(const internal::BlockPattern& pattern);
  // Assembles the normal equations at the current estimate (tangent size D)
  // and returns the robust cost of the window.
  template <int D>
  double linearize();
  // predictAlongPath() in fixed-size arithmetic (tangent size D).
  template <int D>
  Prediction predictAlongPathOf(int factor, const std::vector<int>& path, double variance_factor) const;
  bool takeStep(int first, const Eigen::VectorXd& delta, double cost, IterationResult* result);
  // Powell's dogleg path of one iteration: steepest descent to the Cauchy
  // point, then towards the Gauss-Newton step.
  struct DoglegPath {
    Eigen::VectorXd gauss_newton;  // infinite entries: singular system
    Eigen::VectorXd steepest;      // the Cauchy point
    Eigen::VectorXd at(double radius) const;  // the point of the path at that distance
    double gaussNewtonNorm() const;
  };
  struct TrialStep {
    Eigen::VectorXd step, h_step;  // the step and H times it
    double ratio = -1.0;           // actual over predicted cost decrease
    bool meaningful = false;       // the predicted decrease is above round-off
  };
  // Takes the path's step at `radius` if it lowers the cost (takeStep).
  TrialStep tryStep(int first, const DoglegPath& path, double radius, double cost, IterationResult* result);
  // setStepExtension: from the accepted, truncated step `taken`.
  void extendStep(int first, const DoglegPath& path, double cost, TrialStep* taken, IterationResult* result);
  // Ensures the cached structure is that of the window starting at `first`.
  void prepare(int first);
  // Factorises hessian_; false if it is not positive definite.
  bool factorize();
  // The Gauss-Newton step -H^-1 g at the current linearisation: by
  // conjugate gradients preconditioned with the last factor of this
  // structure while that costs less than a new factorisation (the Hessian
  // changes little between the iterations of a solve: a graduating loop
  // closure's weight is a low-rank change, a small step a small one), else
  // by a new factorisation. CG solves only as exactly as forcing_ asks.
  // Empty if H is not positive definite. `residual`: |H x + g| / |g| reached.
  Eigen::VectorXd gaussNewtonStep(double* residual);
  // Preconditioned conjugate gradients on H x = b, starting from the
  // preconditioned b; false if the residual did not fall below
  // forcing_ |b| within a factorisation's cost; `residual`: |H x - b| / |b| reached.
  bool solveWithLastFactor(const Eigen::VectorXd& b, Eigen::VectorXd* x, double* residual);
  // Whether CG may stop at x with relative residual `relative`: within the
  // forcing term, and exact if x is small enough to end the iterations.
  bool solvedEnough(const Eigen::VectorXd& x, double relative) const;
  // How exactly this iteration's step must solve H x = -g (inexact Newton,
  // Eisenstat & Walker 1996, choice 1 with its safeguard): as exactly as the
  // last step's linear model predicted the gradient it led to. Where the
  // model was poor (a large correction, a changed weight) an exact solve of
  // it buys nothing; near convergence the model is good and the tolerance
  // falls towards kStepTolerance, its floor. Exact for the first iteration
  // of a structure and for a step that may end the caller's iterations
  // (setConvergenceStep). (A step from a new factorisation is exact anyway.)
  void chooseForcingTerm(double gradient_norm);
  // Keeps what the next iteration's forcing term needs: |g| and the
  // model's gradient |g + H s| after the step s just taken (h_step = H s).
  void rememberModel(double gradient_norm, const Eigen::VectorXd& h_step);
  // varianceFactor()'s terms (defined in the .cc file): a factor's are
  // evaluated again once it is marked stale -- its mu, mode or dormancy
  // changed, or an endpoint moved.
  struct VarianceTerms;
  void markStale(int factor) const;
  void poseMoved(int id) const;
  void refreshVarianceTerms() const;
  // J H^-1 J^T for a factor's whitened Jacobian J (J^T: window rows x d,
  // zero above first_row) with the factorised Hessian of the window.
  Eigen::MatrixXd relativeCovariance(const Eigen::MatrixXd& jt, long first_row);
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rhs);
  // rows <- rescale * rows for a residual (columns 1) or a row-major
  // tangent x tangent Jacobian (columns = tangent).
  void applyRescale(const Eigen::MatrixXd& rescale, double* rows, int columns) const;
  double factorCost(const Factor& f, const double* residual) const;
  double windowCost() const;
  void evaluate(const Factor& f, double* residual, double* jac_a, double* jac_b) const;
  // Dijkstra's search from `from` with PathSearch's lengths, towards `to`
  // by A* (see shortestPath), or over every pose it reaches if `to` is -1.
  // Returns the search's id: the poses it reached have visit == id.
  unsigned runSearch(PathSearch* search, int from, int to) const;
  // Distance between the positions of two poses at the current estimate.
  double positionDistance(int a, int b) const;
  const double* blockOf(int id) const { return id == kAnchor ? anchor_.data() : blocks_[id].data(); }

  int dimension_;
  int tangent_;  // 3 or 6
  int ambient_;  // 3 or 7
  double shape_c_;
  std::unique_ptr<ceres::Manifold> manifold_;
  PoseBlock anchor_;
  std::vector<PoseBlock> blocks_;
  std::vector<Factor> factors_;
  std::vector<std::vector<int>> incident_;  // per pose, the factors between it and another pose
  std::vector<std::vector<int>> priors_;    // per pose, the factors between it and kAnchor
  std::unique_ptr<VarianceTerms> variance_terms_;

  // Cached structure (rebuilt when the window or the graph changes).
  int structure_first_ = -1, structure_poses_ = -1, structure_factors_ = -1;
  long structure_version_ = 0, built_version_ = -1;  // bumped when a factor leaves/joins
  std::vector<FactorSlot> slots_;
  std::vector<int> window_factors_;  // collectSlots() scratch space
  std::vector<int> position_;  // variable -> block row of the permuted Hessian
  Eigen::SparseMatrix<double> hessian_;
  Eigen::VectorXd gradient_;
  // Eigen's simplicial LLT on the block-AMD order, its symbolic analysis and
  // numeric factorisation done on the 3x3 (SE(2)) or 6x6 (SE(3)) blocks
  // (src/core/block_simplicial_llt.h; in the .cc file, so that its header
  // stays out of the installed ones).
  // The decomposition holds a factor of this structure's pattern (of an
  // earlier linearisation), and what using it costs, in flops: a new
  // factorisation, and one preconditioned CG iteration (two triangular
  // solves and a product with H).
  bool factor_valid_ = false;
  double factorization_flops_ = 0.0, iteration_flops_ = 0.0;
  // Inexact Newton (chooseForcingTerm): the relative residual this
  // iteration's CG solve must reach, and the last step's model, if a step
  // was taken on this structure.
  double forcing_ = 0.0;
  Eigen::VectorXd noise_scale_;  // setNoiseScale's, per tangent component
  bool noise_scaled_ = false;    // some component > 1
  // Per factor (beside factors_, which evaluate() walks): S, upper
  // triangular, and S D^-1 S^-1 while noise_scaled_.
  std::vector<Eigen::MatrixXd> sqrt_information_, rescale_;
  double convergence_step_ = std::numeric_limits<double>::infinity();
  bool model_known_ = false;
  double model_gradient_norm_ = 0.0, last_gradient_norm_ = 0.0;
  long factorizations_ = 0;
  struct Decompositions;
  std::unique_ptr<Decompositions> decompositions_;
  std::vector<PoseBlock> saved_;
  bool trust_region_ = true;
  bool step_extension_ = false;
  double initial_radius_ = 1.0;
  double radius_ = 1.0;
  double max_radius_ = 1e3;
};

}  // namespace core
}  // namespace agnc_pgo
