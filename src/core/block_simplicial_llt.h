// Eigen's simplicial LL^T (up-looking, on a matrix already ordered and
// stored as its upper triangle), with the symbolic analysis done on the
// block pattern of a pose graph's Hessian instead of on its scalars, and
// (factorizeBlocks(), below) the numeric factorisation on its blocks.
//
// Why. Every structure change (a new window, a pose or loop closure more)
// analyses the pattern again: on the riSAM logs and M3500 that is as often
// as an update, and Eigen's analyzePattern() walked the scalar pattern, d^2
// times the blocks, after copying the matrix twice in its ordering step
// (NaturalOrdering<int> is not the NaturalOrdering<Index> it tests for).
//
// The maths. The Hessian's blocks are dense d x d, so L's are too. Within
// block column J the d scalar columns form a chain in the elimination tree
// (column Jd + c has L(Jd + c + 1, Jd + c) != 0), and the last one's parent
// is the first column of J's parent block. Scalar column Jd + c holds
// d - 1 - c entries below the diagonal in its diagonal block and d per
// block row of L's block column J below it. Both follow from the block
// elimination tree and block column counts, computed by Eigen's own
// algorithm (Liu's, with path marking) on the blocks. The result is the one
// analyzePattern() computes, so the factor is the same to the bit (tested
// against it in test_block_simplicial_llt).
#ifndef AGNC_PGO_SRC_CORE_BLOCK_SIMPLICIAL_LLT_H
#define AGNC_PGO_SRC_CORE_BLOCK_SIMPLICIAL_LLT_H

#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

namespace agnc_pgo {
namespace core {
namespace internal {

// Block rows I <= J present in each block column J of the upper triangle,
// sorted, the diagonal included: rows[start[J]] .. rows[start[J + 1] - 1].
struct BlockPattern {
  std::vector<int> start{0};
  std::vector<int> rows;
  int columns() const { return static_cast<int>(start.size()) - 1; }
};

class BlockSimplicialLLT
    : public Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>> {
  using Base = Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>>;

 public:
  // Replaces analyzePattern() for a matrix of dense `block` x `block` blocks
  // with this upper block pattern; factorize() then works as after it.
  void analyzeBlocks(const BlockPattern& pattern, int block) {
    const int nb = pattern.columns();
    std::vector<int> parent(nb, -1), below(nb, 0), tag(nb, -1);
    for (int k = 0; k < nb; ++k) {
      tag[k] = k;
      for (int p = pattern.start[k]; p < pattern.start[k + 1]; ++p) {
        // Row pattern of L(k, :): every block reachable in the tree from
        // the nonzeros above the diagonal of column k.
        for (int i = pattern.rows[p]; i < k && tag[i] != k; i = parent[i]) {
          if (parent[i] == -1) parent[i] = k;
          ++below[i];
          tag[i] = k;
        }
      }
    }
    const int n = nb * block;
    m_matrix.resize(n, n);
    m_parent.resize(n);
    m_nonZerosPerCol.resize(n);
    int* lp = m_matrix.outerIndexPtr();
    lp[0] = 0;
    for (int j = 0; j < nb; ++j) {
      for (int c = 0; c < block; ++c) {
        const int s = j * block + c;
        m_parent[s] = c + 1 < block ? s + 1 : (parent[j] < 0 ? -1 : parent[j] * block);
        m_nonZerosPerCol[s] = block - 1 - c + block * below[j];
        lp[s + 1] = lp[s] + m_nonZerosPerCol[s] + 1;  // LL^T stores the diagonal
      }
    }
    m_matrix.resizeNonZeros(lp[n]);
    block_ = block;
    block_parent_ = std::move(parent);
    m_P.resize(0);
    m_Pinv.resize(0);
    this->Eigen::SparseSolverBase<Base>::m_isInitialized = true;
    m_info = Eigen::Success;
    m_analysisIsOk = true;
    m_factorizationIsOk = false;
  }

  // The numeric factorisation after analyzeBlocks(), on d x d blocks: the
  // up-looking algorithm of Eigen's factorize(), one block row of L at a
  // time. Block row K solves L(0:K, 0:K) X = A(0:K, K) by forward
  // substitution over the blocks of its row pattern (the block tree's paths
  // from A's blocks up to K, in topological order): X_I = L_II^-1 Y_I, then
  // Y_R -= L_RI X_I for the block rows R stored in column block I, and
  // L(K, I) = X_I^T; the diagonal block is the dense Cholesky factor of
  // A_KK - sum X_I^T X_I. Same pattern and storage as factorize() leaves,
  // so solve() and matrixL() work as after it; the values agree with it
  // to rounding (the sums run in another order), the pattern is walked once
  // per block row instead of once per scalar row, and the arithmetic is on
  // fixed-size d x d blocks. `a` holds whole d x d blocks (the upper
  // triangle of the diagonal ones), as for analyzeBlocks().
  void factorizeBlocks(const Eigen::SparseMatrix<double>& a) {
    if (block_ == 3) return factorizeFixed<3>(a);
    if (block_ == 6) return factorizeFixed<6>(a);
    factorize(a);
  }

 private:
  template <int D>
  using Block = Eigen::Matrix<double, D, D>;

  template <int D>
  Eigen::Map<Block<D>> rhs(int block) {  // Y_I, column-major in work_
    return Eigen::Map<Block<D>>(work_.data() + static_cast<size_t>(block) * D * D);
  }

  template <int D>
  void factorizeFixed(const Eigen::SparseMatrix<double>& a) {
    const int nb = static_cast<int>(block_parent_.size());
    work_.assign(static_cast<size_t>(nb) * D * D, 0.0);
    tags_.assign(nb, -1);
    pattern_.resize(nb);
    stored_.assign(nb, 0);
    bool ok = true;
    for (int k = 0; k < nb && ok; ++k) {
      Block<D> diagonal = Block<D>::Zero();
      for (int top = scatterBlockColumn<D>(a, k, &diagonal); top < nb; ++top)
        eliminateBlock<D>(pattern_[top], k, &diagonal);
      ok = storeDiagonalBlock<D>(k, diagonal);
    }
    m_info = ok ? Eigen::Success : Eigen::NumericalIssue;
    m_factorizationIsOk = true;
  }

  // A's block column k: its diagonal block into `diagonal`, the others
  // added to Y_I; the row pattern of L's block row k, in topological order,
  // left in pattern_[top, nb) (Eigen's path marking, on the block tree).
  template <int D>
  int scatterBlockColumn(const Eigen::SparseMatrix<double>& a, int k, Block<D>* diagonal) {
    const int* ap = a.outerIndexPtr();
    const int* ai = a.innerIndexPtr();
    const double* ax = a.valuePtr();
    int top = static_cast<int>(block_parent_.size());
    tags_[k] = k;
    for (int c = 0; c < D; ++c) {
      for (int p = ap[k * D + c]; p < ap[k * D + c + 1]; ++p) {
        const int i = ai[p] / D, r = ai[p] % D;
        if (i == k) {
          (*diagonal)(r, c) = (*diagonal)(c, r) = ax[p];
          continue;
        }
        rhs<D>(i)(r, c) += ax[p];
        int length = 0;
        for (int j = i; tags_[j] != k; j = block_parent_[j]) {
          pattern_[length++] = j;
          tags_[j] = k;
        }
        while (length > 0) pattern_[--top] = pattern_[--length];
      }
    }
    return top;
  }

  // One step of block row k's forward substitution: X = L_ii^-1 Y_i, then
  // Y_R -= L_Ri X for the block rows R stored in block column i, the
  // diagonal block's Schur complement, and L(k, i) = X^T stored.
  template <int D>
  void eliminateBlock(int i, int k, Block<D>* diagonal) {
    const int* lp = m_matrix.outerIndexPtr();
    int* li = m_matrix.innerIndexPtr();
    double* lx = m_matrix.valuePtr();
    Block<D> lii = Block<D>::Zero();
    int base[D];  // where the block rows below the diagonal block start, per scalar column
    for (int c = 0; c < D; ++c) {
      for (int r = c; r < D; ++r) lii(r, c) = lx[lp[i * D + c] + (r - c)];
      base[c] = lp[i * D + c] + (D - c);
    }
    Eigen::Map<Block<D>> yi = rhs<D>(i);
    Block<D> x;  // by hand: Eigen's triangular solve takes its dynamic-size path here
    for (int j = 0; j < D; ++j)
      for (int r = 0; r < D; ++r) {
        double sum = yi(r, j);
        for (int c = 0; c < r; ++c) sum -= lii(r, c) * x(c, j);
        x(r, j) = sum / lii(r, r);
      }
    yi.setZero();
    for (int s = 0; s < stored_[i]; ++s) {
      Block<D> lri;
      for (int c = 0; c < D; ++c) lri.col(c) = Eigen::Map<const Eigen::Matrix<double, D, 1>>(lx + base[c] + D * s);
      rhs<D>(li[base[0] + D * s] / D).noalias() -= lri * x;
    }
    diagonal->noalias() -= x.transpose() * x;
    for (int c = 0; c < D; ++c)
      for (int r = 0; r < D; ++r) {
        li[base[c] + D * stored_[i] + r] = k * D + r;
        lx[base[c] + D * stored_[i] + r] = x(c, r);
      }
    ++stored_[i];
  }

  // L_kk, the dense Cholesky factor of what is left of A_kk; false if that
  // is not positive definite.
  template <int D>
  bool storeDiagonalBlock(int k, const Block<D>& diagonal) {
    const int* lp = m_matrix.outerIndexPtr();
    const Eigen::LLT<Block<D>> llt(diagonal);
    const Block<D> lkk = llt.matrixL();
    for (int c = 0; c < D; ++c)
      for (int r = c; r < D; ++r) {
        m_matrix.innerIndexPtr()[lp[k * D + c] + (r - c)] = k * D + r;
        m_matrix.valuePtr()[lp[k * D + c] + (r - c)] = lkk(r, c);
      }
    return llt.info() == Eigen::Success;
  }

  int block_ = 0;
  std::vector<int> block_parent_;
  std::vector<double> work_;
  std::vector<int> tags_, pattern_;
  std::vector<int> stored_;  // block rows stored so far below each diagonal block
};

}  // namespace internal
}  // namespace core
}  // namespace agnc_pgo

#endif  // AGNC_PGO_SRC_CORE_BLOCK_SIMPLICIAL_LLT_H
