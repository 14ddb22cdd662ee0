// The block symbolic analysis and the block numeric factorisation
// (src/core/block_simplicial_llt.h) against Eigen's own analyzePattern()
// and factorize(): the same factor, to the bit after Eigen's scalar
// factorisation, to rounding after the block one, on random block patterns
// stored as the solver stores its Hessian (dense d x d blocks, upper block
// triangle, diagonal blocks whole).
#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/block_simplicial_llt.h"

namespace agnc_pgo {
namespace core {
namespace {

using internal::BlockPattern;
using internal::BlockSimplicialLLT;

struct BlockMatrix {
  BlockPattern pattern;
  Eigen::SparseMatrix<double> upper;
};

// A random graph over `blocks` nodes (a chain and `extra` random pairs), its
// pattern and an SPD matrix of d x d blocks on it: sum of J^T J per pair
// plus a diagonal that keeps it positive definite.
BlockMatrix randomBlockMatrix(int blocks, int extra, int d, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> node(0, blocks - 1);
  std::normal_distribution<double> value;
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i + 1 < blocks; ++i) pairs.emplace_back(i, i + 1);
  for (int k = 0; k < extra; ++k) {
    const int a = node(random), b = node(random);
    if (a != b) pairs.emplace_back(a, b);
  }
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(blocks * d, blocks * d);
  for (const auto& [a, b] : pairs) {
    Eigen::MatrixXd j(d, 2 * d);
    for (int r = 0; r < d; ++r)
      for (int c = 0; c < 2 * d; ++c) j(r, c) = value(random);
    const Eigen::MatrixXd h = j.transpose() * j;
    for (int x = 0; x < 2; ++x)
      for (int y = 0; y < 2; ++y)
        dense.block((x ? b : a) * d, (y ? b : a) * d, d, d) += h.block(x * d, y * d, d, d);
  }
  dense.diagonal().array() += 1.0;

  BlockMatrix m;
  std::vector<std::vector<int>> rows(blocks);
  for (int j = 0; j < blocks; ++j) rows[j].push_back(j);
  for (const auto& [a, b] : pairs) rows[std::max(a, b)].push_back(std::min(a, b));
  for (int j = 0; j < blocks; ++j) {
    std::sort(rows[j].begin(), rows[j].end());
    rows[j].erase(std::unique(rows[j].begin(), rows[j].end()), rows[j].end());
    m.pattern.rows.insert(m.pattern.rows.end(), rows[j].begin(), rows[j].end());
    m.pattern.start.push_back(static_cast<int>(m.pattern.rows.size()));
  }
  std::vector<Eigen::Triplet<double>> entries;
  for (int j = 0; j < blocks; ++j)
    for (int i : rows[j])
      for (int c = 0; c < d; ++c)
        for (int r = 0; r < d; ++r) entries.emplace_back(i * d + r, j * d + c, dense(i * d + r, j * d + c));
  m.upper.resize(blocks * d, blocks * d);
  m.upper.setFromTriplets(entries.begin(), entries.end());
  return m;
}

// The numeric factorisation after the block analysis: Eigen's scalar one
// (the same operations as after Eigen's own analysis: equal to the bit) or
// the block one (the sums in another order: equal to rounding).
enum class Numeric { kScalar, kBlocks };

// Against Eigen's own analysis and factorisation: the same pattern and
// storage, the values as `numeric` promises, a solve as exact.
void expectFactorAsEigens(const BlockMatrix& m, int d, Numeric numeric) {
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>> eigen;
  eigen.analyzePattern(m.upper);
  eigen.factorize(m.upper);
  ASSERT_EQ(eigen.info(), Eigen::Success);
  BlockSimplicialLLT blocks;
  blocks.analyzeBlocks(m.pattern, d);
  if (numeric == Numeric::kScalar)
    blocks.factorize(m.upper);
  else
    blocks.factorizeBlocks(m.upper);
  ASSERT_EQ(blocks.info(), Eigen::Success);

  const Eigen::SparseMatrix<double>& expected = eigen.matrixL().nestedExpression();
  const Eigen::SparseMatrix<double>& actual = blocks.matrixL().nestedExpression();
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.nonZeros(), expected.nonZeros());
  for (int k = 0; k <= expected.cols(); ++k) ASSERT_EQ(actual.outerIndexPtr()[k], expected.outerIndexPtr()[k]);
  const double scale = Eigen::Map<const Eigen::VectorXd>(expected.valuePtr(), expected.nonZeros()).cwiseAbs().maxCoeff();
  const double tolerance = numeric == Numeric::kScalar ? 0.0 : 1e-13 * scale;
  for (long k = 0; k < expected.nonZeros(); ++k) {
    ASSERT_EQ(actual.innerIndexPtr()[k], expected.innerIndexPtr()[k]) << "entry " << k;
    ASSERT_NEAR(actual.valuePtr()[k], expected.valuePtr()[k], tolerance) << "entry " << k;
  }
  const Eigen::VectorXd rhs = Eigen::VectorXd::LinSpaced(m.upper.rows(), -1.0, 1.0);
  const Eigen::VectorXd x = blocks.solve(rhs);
  const Eigen::SparseMatrix<double> symmetric = m.upper.selfadjointView<Eigen::Upper>();
  EXPECT_LT((symmetric * x - rhs).norm(), 1e-9 * rhs.norm());
}

TEST(BlockSimplicialLLT, FactorsAsEigensScalarAnalysisDoes2D) {
  for (unsigned seed = 1; seed <= 20; ++seed) expectFactorAsEigens(randomBlockMatrix(40, 15, 3, seed), 3, Numeric::kScalar);
}

TEST(BlockSimplicialLLT, FactorsAsEigensScalarAnalysisDoes3D) {
  for (unsigned seed = 1; seed <= 10; ++seed) expectFactorAsEigens(randomBlockMatrix(25, 10, 6, seed), 6, Numeric::kScalar);
}

TEST(BlockSimplicialLLT, BlockFactorisationAgreesWithEigens2D) {
  for (unsigned seed = 1; seed <= 20; ++seed) expectFactorAsEigens(randomBlockMatrix(60, 25, 3, seed), 3, Numeric::kBlocks);
}

TEST(BlockSimplicialLLT, BlockFactorisationAgreesWithEigens3D) {
  for (unsigned seed = 1; seed <= 10; ++seed) expectFactorAsEigens(randomBlockMatrix(40, 15, 6, seed), 6, Numeric::kBlocks);
}

TEST(BlockSimplicialLLT, BlockFactorisationFallsBackForOtherBlockSizes) {
  for (unsigned seed = 1; seed <= 5; ++seed) expectFactorAsEigens(randomBlockMatrix(25, 10, 4, seed), 4, Numeric::kBlocks);
}

TEST(BlockSimplicialLLT, BlockFactorisationRefusesAnIndefiniteMatrix) {
  for (int d : {3, 6}) {
    BlockMatrix m = randomBlockMatrix(30, 10, d, 7);
    // Block 20's diagonal made negative: positive definite no longer.
    for (Eigen::SparseMatrix<double>::InnerIterator it(m.upper, 20 * d + 1); it; ++it)
      if (it.row() == it.col()) it.valueRef() = -1e3;
    BlockSimplicialLLT blocks;
    blocks.analyzeBlocks(m.pattern, d);
    blocks.factorizeBlocks(m.upper);
    EXPECT_EQ(blocks.info(), Eigen::NumericalIssue) << "d = " << d;
    blocks.factorizeBlocks(randomBlockMatrix(30, 10, d, 7).upper);  // and recovers on the next
    EXPECT_EQ(blocks.info(), Eigen::Success) << "d = " << d;
  }
}

// A forest: pairs only within two halves, so the block tree has two roots.
TEST(BlockSimplicialLLT, FactorsADisconnectedPattern) {
  BlockMatrix m = randomBlockMatrix(10, 0, 3, 3);
  // Cut the chain between blocks 4 and 5: drop block row 4 from column 5.
  std::vector<Eigen::Triplet<double>> entries;
  for (int k = 0; k < m.upper.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(m.upper, k); it; ++it)
      if (!(it.row() / 3 == 4 && it.col() / 3 == 5)) entries.emplace_back(it.row(), it.col(), it.value());
  m.upper.setFromTriplets(entries.begin(), entries.end());
  std::vector<int>& rows = m.pattern.rows;
  const int first = m.pattern.start[5];
  ASSERT_EQ(rows[first], 4);
  rows.erase(rows.begin() + first);
  for (size_t j = 6; j < m.pattern.start.size(); ++j) --m.pattern.start[j];
  expectFactorAsEigens(m, 3, Numeric::kScalar);
}

}  // namespace
}  // namespace core
}  // namespace agnc_pgo
