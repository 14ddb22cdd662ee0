// Eigen's simplicial LL^T (up-looking, on a matrix already ordered and
// stored as its upper triangle), with the symbolic analysis done on the
// block pattern of a pose graph's Hessian instead of on its scalars.
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

#include <vector>

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
    m_P.resize(0);
    m_Pinv.resize(0);
    this->Eigen::SparseSolverBase<Base>::m_isInitialized = true;
    m_info = Eigen::Success;
    m_analysisIsOk = true;
    m_factorizationIsOk = false;
  }
};

}  // namespace internal
}  // namespace core
}  // namespace agnc_pgo

#endif  // AGNC_PGO_SRC_CORE_BLOCK_SIMPLICIAL_LLT_H
