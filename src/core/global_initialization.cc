#include "agnc_pgo/core/global_initialization.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

namespace agnc_pgo {
namespace core {
namespace {

using PoseVector = std::vector<Pose, Eigen::aligned_allocator<Pose>>;

// The edges and gauge the initialisation works with.
struct Problem {
  int num_poses = 0;
  std::vector<const Edge*> edges;  // used edges, ids checked, no self-loops
  std::vector<bool> fixed;         // per id: part of the gauge
  PoseVector values;               // per id: the graph's pose (identity where it has none)
  std::vector<int> roots;          // the gauge ids, in the graph's order
};

Problem makeProblem(const PoseGraph& graph, const GlobalInitializationOptions& options) {
  Problem p;
  p.num_poses = static_cast<int>(graph.poses.size());
  for (const Edge& e : graph.edges) {
    if (e.from < 0 || e.to < 0)
      throw std::invalid_argument("globalInitialization: negative pose id in edge " + std::to_string(e.from) +
                                  " -> " + std::to_string(e.to));
    if (options.skip_outliers && e.is_outlier) continue;
    p.num_poses = std::max({p.num_poses, e.from + 1, e.to + 1});
    if (e.from != e.to) p.edges.push_back(&e);
  }
  p.values.assign(p.num_poses, Pose::identity());
  std::copy(graph.poses.begin(), graph.poses.end(), p.values.begin());
  p.roots = graph.fixed;
  if (p.roots.empty() && p.num_poses > 0) p.roots.push_back(0);
  p.fixed.assign(p.num_poses, false);
  for (int id : p.roots) {
    if (id < 0 || id >= p.num_poses)
      throw std::invalid_argument("globalInitialization: fixed pose " + std::to_string(id) + " does not exist");
    p.fixed[id] = true;
  }
  return p;
}

// ---------------------------------------------------------------- spanning trees

using Adjacency = std::vector<std::vector<int>>;  // per pose, the edges (indices into p.edges) it may be reached by

int findRoot(std::vector<int>* parent, int i) {
  while ((*parent)[i] != i) i = (*parent)[i] = (*parent)[(*parent)[i]];
  return i;
}

bool isOdometry(const Edge& e) { return e.kind == EdgeKind::kOdometry && std::abs(e.from - e.to) == 1; }

// Kruskal without weights: odometry edges first, so the tree is the odometry
// chain wherever it exists and loop closures only bridge its gaps.
Adjacency odometryTree(const Problem& p) {
  std::vector<int> ordered(p.edges.size());
  std::iota(ordered.begin(), ordered.end(), 0);
  std::stable_partition(ordered.begin(), ordered.end(), [&p](int k) { return isOdometry(*p.edges[k]); });
  std::vector<int> parent(p.num_poses);
  std::iota(parent.begin(), parent.end(), 0);
  Adjacency adjacent(p.num_poses);
  for (int k : ordered) {
    const Edge* e = p.edges[k];
    const int a = findRoot(&parent, e->from), b = findRoot(&parent, e->to);
    if (a == b) continue;
    parent[a] = b;
    adjacent[e->from].push_back(k);
    adjacent[e->to].push_back(k);
  }
  return adjacent;
}

// Every edge, odometry first: a breadth-first traversal of it is a
// shortest-path tree, whose cycles through a loop closure are short.
Adjacency allEdges(const Problem& p) {
  Adjacency adjacent(p.num_poses);
  for (int k = 0; k < static_cast<int>(p.edges.size()); ++k) {
    adjacent[p.edges[k]->from].push_back(k);
    adjacent[p.edges[k]->to].push_back(k);
  }
  for (std::vector<int>& edges : adjacent)
    std::stable_partition(edges.begin(), edges.end(), [&p](int k) { return isOdometry(*p.edges[k]); });
  return adjacent;
}

// Heading of every pose composed breadth-first through `adjacent` from
// `root` (then from the gauge poses, for components without the root), by
// the edges' measured headings `yaw` (per edge; empty: connectivity only).
// Throws if a pose is not reached.
std::vector<double> treeHeadings(const Problem& p, const Adjacency& adjacent, int root,
                                 const std::vector<double>& yaw) {
  std::vector<double> heading(p.num_poses, 0.0);
  std::vector<bool> reached(p.num_poses, false);
  std::vector<int> sources{root};
  sources.insert(sources.end(), p.roots.begin(), p.roots.end());
  for (int source : sources) {
    if (reached[source]) continue;
    reached[source] = true;
    heading[source] = yaw.empty() ? 0.0 : p.values[source].yaw();
    std::deque<int> queue{source};
    while (!queue.empty()) {
      const int a = queue.front();
      queue.pop_front();
      for (int k : adjacent[a]) {
        const Edge* e = p.edges[k];
        const int b = e->from == a ? e->to : e->from;
        if (reached[b]) continue;
        const double z = yaw.empty() ? 0.0 : yaw[k];
        heading[b] = heading[a] + (e->from == a ? z : -z);
        reached[b] = true;
        queue.push_back(b);
      }
    }
  }
  for (int i = 0; i < p.num_poses; ++i) {
    if (!reached[i])
      throw std::invalid_argument("globalInitialization: pose " + std::to_string(i) +
                                  " is not connected to the fixed pose " + std::to_string(p.roots.front()));
  }
  return heading;
}

// ---------------------------------------------------------------- linear least squares

// Weighted linear least squares over one k-vector per pose, built from
// relative constraints x_j - M x_i = d with weight W; gauge poses are known.
// The matrix depends only on the terms' M and W, so it is factorised once
// and solved for every right-hand side asked (the headings are solved
// against several trees, each its own d and gauge values).
class RelativeLeastSquares {
 public:
  RelativeLeastSquares(const Problem& p, int k) : k_(k), index_(p.num_poses, -1) {
    for (int i = 0; i < p.num_poses; ++i)
      if (!p.fixed[i]) index_[i] = unknowns_++;
  }

  // Adds the term x_j - M x_i = d; its d comes with solve(), in add() order.
  void add(int i, int j, const Eigen::MatrixXd& M, const Eigen::MatrixXd& W) {
    const int vi = index_[i], vj = index_[j];
    Term term{i, j, W, M.transpose() * W};
    if (vj >= 0) addBlock(vj, vj, W);
    if (vi >= 0) addBlock(vi, vi, term.MtW * M);
    if (vi >= 0 && vj >= 0) {
      addBlock(vi, vj, -term.MtW);
      addBlock(vj, vi, -term.MtW.transpose());
    }
    terms_.push_back(std::move(term));
  }

  // Every pose's vector given the terms' d (stacked in add() order) and the
  // gauge poses' values in `known`.
  Eigen::VectorXd solve(const Eigen::VectorXd& d, const Eigen::VectorXd& known, const char* what) {
    if (unknowns_ == 0) return known;  // every pose is a gauge pose
    if (!ldlt_) factorize(what);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns_ * k_);
    for (size_t t = 0; t < terms_.size(); ++t) {
      const Term& term = terms_[t];
      const int vi = index_[term.i], vj = index_[term.j];
      const auto dt = d.segment(t * k_, k_);
      if (vj >= 0) {
        rhs.segment(vj * k_, k_) += term.W * dt;
        if (vi < 0) rhs.segment(vj * k_, k_) += term.MtW.transpose() * known.segment(term.i * k_, k_);
      }
      if (vi >= 0) {
        rhs.segment(vi * k_, k_) -= term.MtW * dt;
        if (vj < 0) rhs.segment(vi * k_, k_) += term.MtW * known.segment(term.j * k_, k_);
      }
    }
    const Eigen::VectorXd x = ldlt_->solve(rhs);
    if (ldlt_->info() != Eigen::Success || !x.allFinite()) throw singular(what);
    Eigen::VectorXd all = known;
    for (size_t i = 0; i < index_.size(); ++i)
      if (index_[i] >= 0) all.segment(i * k_, k_) = x.segment(index_[i] * k_, k_);
    return all;
  }

 private:
  struct Term {
    int i, j;
    Eigen::MatrixXd W, MtW;  // the weight and M^T W
  };

  static std::runtime_error singular(const char* what) {
    return std::runtime_error(std::string("globalInitialization: the ") + what +
                              " system is singular (an edge with zero information?)");
  }

  void factorize(const char* what) {
    Eigen::SparseMatrix<double> H(unknowns_ * k_, unknowns_ * k_);
    H.setFromTriplets(triplets_.begin(), triplets_.end());
    ldlt_ = std::make_unique<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>>(H);
    if (ldlt_->info() != Eigen::Success || ldlt_->vectorD().minCoeff() <= 0.0) throw singular(what);
  }

  void addBlock(int row, int col, const Eigen::MatrixXd& block) {
    for (int r = 0; r < k_; ++r)
      for (int c = 0; c < k_; ++c)
        if (block(r, c) != 0.0) triplets_.emplace_back(row * k_ + r, col * k_ + c, block(r, c));
  }

  int k_;
  int unknowns_ = 0;
  std::vector<int> index_;  // id -> unknown index, -1 for a gauge pose
  std::vector<Term> terms_;
  std::vector<Eigen::Triplet<double>> triplets_;
  std::unique_ptr<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>> ldlt_;  // on the first solve
};

// Information of the rotation part alone (the translation marginalised out):
// the inverse of the rotation block of the covariance. The rotation block of
// the information itself would overrate the angle of coupled measurements.
Eigen::MatrixXd marginalRotationInformation(const Eigen::MatrixXd& information, int rotation_dim) {
  const Eigen::MatrixXd sym = 0.5 * (information + information.transpose());
  const int n = static_cast<int>(sym.rows());
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(sym);
  const Eigen::MatrixXd covariance = ldlt.solve(Eigen::MatrixXd::Identity(n, n));
  const Eigen::MatrixXd block = covariance.bottomRightCorner(rotation_dim, rotation_dim);
  const Eigen::LDLT<Eigen::MatrixXd> block_ldlt(block);
  if (ldlt.info() == Eigen::Success && block_ldlt.isPositive() && covariance.allFinite()) {
    const Eigen::MatrixXd marginal = block_ldlt.solve(Eigen::MatrixXd::Identity(rotation_dim, rotation_dim));
    if (marginal.allFinite() && marginal.trace() > 0.0) return marginal;
  }
  return sym.bottomRightCorner(rotation_dim, rotation_dim);  // singular information: best effort
}

Eigen::MatrixXd translationInformation(const Eigen::MatrixXd& information, int translation_dim) {
  const Eigen::MatrixXd block = information.topLeftCorner(translation_dim, translation_dim);
  return 0.5 * (block + block.transpose());
}

// Positions given the rotations: t_j - t_i = R_i t_ij, weighted by the
// translation information rotated into the world frame.
template <int D>
std::vector<Eigen::Matrix<double, D, 1>> solvePositions(
    const Problem& p, const std::vector<Eigen::Matrix<double, D, D>>& rotations) {
  Eigen::VectorXd known = Eigen::VectorXd::Zero(p.num_poses * D);
  for (int i = 0; i < p.num_poses; ++i) known.segment<D>(i * D) = p.values[i].translation.head<D>();
  RelativeLeastSquares system(p, D);
  Eigen::VectorXd d(p.edges.size() * D);
  const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(D, D);
  for (size_t k = 0; k < p.edges.size(); ++k) {
    const Edge* e = p.edges[k];
    const Eigen::Matrix<double, D, D>& R = rotations[e->from];
    system.add(e->from, e->to, identity, R * translationInformation(e->information, D) * R.transpose());
    d.segment<D>(k * D) = R * e->measurement.translation.head<D>();
  }
  const Eigen::VectorXd x = system.solve(d, known, "position");
  std::vector<Eigen::Matrix<double, D, 1>> positions(p.num_poses);
  for (int i = 0; i < p.num_poses; ++i) positions[i] = x.segment<D>(i * D);
  return positions;
}

// ---------------------------------------------------------------- SE(2)

struct Headings {
  std::vector<double> heading;  // per pose
  double cost = 0;              // weighted squared angle residual of the solve
};

// The linear angle problem: one term per edge, weighted by its marginal
// rotation information; the trees only change its right-hand side.
struct AngleSystem {
  explicit AngleSystem(const Problem& p) : system(p, 1), weight(p.edges.size()), yaw(p.edges.size()) {
    for (size_t k = 0; k < p.edges.size(); ++k) {
      const Edge& e = *p.edges[k];
      yaw[k] = e.measurement.yaw();
      weight[k] = marginalRotationInformation(e.information, 1)(0, 0);
      system.add(e.from, e.to, Eigen::MatrixXd::Identity(1, 1), Eigen::MatrixXd::Constant(1, 1, weight[k]));
    }
  }
  RelativeLeastSquares system;
  std::vector<double> weight;  // per edge
  std::vector<double> yaw;     // per edge, its measured heading (computed once for every tree)
};

// Headings from the linear angle problem, each measured angle taken in the
// 2*pi branch within (-pi, pi] of what the tree says.
Headings solveHeadingsAgainst(const Problem& p, AngleSystem* angles, const std::vector<double>& tree) {
  Eigen::VectorXd known(p.num_poses);
  for (int i = 0; i < p.num_poses; ++i) {
    // A gauge pose keeps its heading, taken in the tree's 2*pi branch.
    known(i) = p.fixed[i] ? tree[i] + wrapAngle(p.values[i].yaw() - tree[i]) : tree[i];
  }
  Eigen::VectorXd regularised(p.edges.size());
  for (size_t k = 0; k < p.edges.size(); ++k) {
    const Edge& e = *p.edges[k];
    const double tree_difference = tree[e.to] - tree[e.from];
    regularised(k) = tree_difference - wrapAngle(tree_difference - angles->yaw[k]);
  }
  const Eigen::VectorXd x = angles->system.solve(regularised, known, "angle");
  Headings h;
  h.heading.assign(x.data(), x.data() + x.size());
  for (size_t k = 0; k < p.edges.size(); ++k) {
    const double r = x(p.edges[k]->to) - x(p.edges[k]->from) - regularised(k);
    h.cost += angles->weight[k] * r * r;
  }
  return h;
}

// The 2*pi regularisation is only as good as the tree: where the noise summed
// around a cycle through the tree exceeds pi, a loop closure is taken in the
// wrong branch and the solve bends the map (M3500b, 0.25 rad per edge, from
// the odometry chain: LM then ends at chi2 11139 against 2055 from the ground
// truth). A wrong branch leaves a residual of order 2*pi on its cycle, so the
// angle cost tells the trees apart: the odometry chain and shortest-path trees
// from kTreeRoots poses spread over the ids are tried, the lowest cost kept.
constexpr int kTreeRoots = 8;

std::vector<double> solveHeadings(const Problem& p) {
  AngleSystem angles(p);
  Headings best = solveHeadingsAgainst(p, &angles, treeHeadings(p, odometryTree(p), p.roots.front(), angles.yaw));
  const Adjacency adjacent = allEdges(p);
  for (int k = 0; k < kTreeRoots; ++k) {
    const int root = static_cast<int>(static_cast<long>(k) * p.num_poses / kTreeRoots);
    Headings candidate = solveHeadingsAgainst(p, &angles, treeHeadings(p, adjacent, root, angles.yaw));
    if (candidate.cost < best.cost) best = std::move(candidate);
  }
  return best.heading;
}

PoseVector initialize2d(const Problem& p) {
  const std::vector<double> headings = solveHeadings(p);
  std::vector<Eigen::Matrix2d> rotations(p.num_poses);
  for (int i = 0; i < p.num_poses; ++i) rotations[i] = Eigen::Rotation2Dd(headings[i]).toRotationMatrix();
  const std::vector<Eigen::Vector2d> positions = solvePositions<2>(p, rotations);
  PoseVector poses(p.num_poses);
  for (int i = 0; i < p.num_poses; ++i) poses[i] = Pose::fromSE2(positions[i].x(), positions[i].y(), headings[i]);
  return poses;
}

// ---------------------------------------------------------------- SE(3)

Eigen::Matrix3d projectToRotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

// Chordal relaxation: min sum_ij w_ij |R_j - R_i R_ij|_F^2 over unconstrained
// 3x3 matrices, then each projected onto SO(3). With an isotropic weight the
// cost separates by rows: row r of R_j is row r of R_i times R_ij, so the
// three rows are three solves of one 3-vector system, R_ij^T as its M.
std::vector<Eigen::Matrix3d> solveRotations(const Problem& p) {
  treeHeadings(p, odometryTree(p), p.roots.front(), {});  // connectivity check only
  std::vector<Eigen::Matrix3d> gauge(p.num_poses);
  for (int i = 0; i < p.num_poses; ++i) gauge[i] = p.values[i].rotation.normalized().toRotationMatrix();
  RelativeLeastSquares system(p, 3);
  for (const Edge* e : p.edges) {
    const Eigen::Matrix3d Rij = e->measurement.rotation.normalized().toRotationMatrix();
    // Isotropic weight: the chordal cost cannot take a rotation covariance's shape.
    const double w = marginalRotationInformation(e->information, 3).trace() / 3.0;
    system.add(e->from, e->to, Rij.transpose(), w * Eigen::MatrixXd::Identity(3, 3));
  }
  std::vector<Eigen::Matrix3d> relaxed(p.num_poses);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(p.edges.size() * 3);
  for (int row = 0; row < 3; ++row) {
    Eigen::VectorXd known(p.num_poses * 3);
    for (int i = 0; i < p.num_poses; ++i) known.segment<3>(i * 3) = gauge[i].row(row).transpose();
    const Eigen::VectorXd x = system.solve(zero, known, "chordal rotation");
    for (int i = 0; i < p.num_poses; ++i) relaxed[i].row(row) = x.segment<3>(i * 3).transpose();
  }
  std::vector<Eigen::Matrix3d> rotations(p.num_poses);
  for (int i = 0; i < p.num_poses; ++i) rotations[i] = p.fixed[i] ? relaxed[i] : projectToRotation(relaxed[i]);
  return rotations;
}

PoseVector initialize3d(const Problem& p) {
  const std::vector<Eigen::Matrix3d> rotations = solveRotations(p);
  const std::vector<Eigen::Vector3d> positions = solvePositions<3>(p, rotations);
  PoseVector poses(p.num_poses);
  for (int i = 0; i < p.num_poses; ++i) {
    poses[i].translation = positions[i];
    poses[i].rotation = p.fixed[i] ? p.values[i].rotation : Eigen::Quaterniond(rotations[i]).normalized();
  }
  return poses;
}

}  // namespace

PoseVector globalInitialization(const PoseGraph& graph, const GlobalInitializationOptions& options) {
  if (graph.dimension != 2 && graph.dimension != 3)
    throw std::invalid_argument("globalInitialization: dimension must be 2 or 3, not " +
                                std::to_string(graph.dimension));
  const Problem problem = makeProblem(graph, options);
  if (problem.num_poses == 0) return {};
  return graph.dimension == 2 ? initialize2d(problem) : initialize3d(problem);
}

}  // namespace core
}  // namespace agnc_pgo
