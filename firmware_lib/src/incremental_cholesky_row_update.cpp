// The row update of IncrementalCholesky: L L^T + A^T A for the whitened rows A of an added factor,
// by orthogonal transformations of [L(:,k) A(:,k)^T] along the etree path (see the header).
//
// Why it is cheap: adding a factor between an old pose i and the newest pose changes exactly the
// columns on the (updated) etree path from i to the root. factorize() recomputes each of them
// from its old value, sending every updated-minus-old outer product L(r,k) L(s,k)^T to the
// columns of its structure: s^2 block products for a column of structure s. Here column k and
// the factor's rows are rotated together, [L(:,k) W(:,k)] Q = [L'(:,k) W'(:,k)], and only W'
// travels on to the parent: about 3 s block products (Q kept as D reflections). In a graph whose
// top is a dense clique of ~100 columns (city10000 after COLAMD) that is the difference between
// ~10^6 and ~10^4 products per loop closure. Orthogonal transformations also add no cancellation.
//
// The right-hand side rides along as one more row: L d = eta is the last row of the Cholesky
// factor of [Lambda eta; eta^T .], so [d(k)^T b^T] Q = [d'(k)^T b'^T] updates d on the same path.
#include <cmath>

#include "lower_triangular.h"
#include "lslam/linear/block_kernels.h"
#include "lslam/linear/incremental_cholesky.h"

namespace lslam {
namespace {

// The D Householder reflections H_j = I - beta_j v_j v_j^T (2D x 2D) with [l w] H_0 ... H_{D-1} =
// [l' 0], l' lower-triangular with a positive diagonal, for l lower-triangular (D x D, possibly
// zero for an added column) and w (D x D). H_j zeroes row j right of the diagonal (Golub & Van
// Loan 5.1.1, sign chosen so that the kept entry is +norm). Entries of row j right of the diagonal
// within l are still zero when H_j is formed (H_0 .. H_{j-1} only mix l's columns 0 .. j-1 with
// w), so v_j = e_j + [0; u_j]: applying H_j to a row costs 2D + 2 multiply-adds, against 4D for
// the row times an explicit Q, which is why the reflections are kept in this factored form.
template <int D>
struct RowReflections {
  Eigen::Matrix<double, D, D> u;  // column j: the w part of v_j
  Eigen::Matrix<double, D, 1> beta;

  // [x_l x_w] H_0 ... H_{D-1} for the rows of x_l (any count), in place.
  template <typename XL, typename XW>
  void apply(XL& x_l, XW& x_w) const {
    detail::applyRowReflections<D>(u, beta, x_l, x_w);
  }
};

// [L(r, k) W(r)] H_0 ... H_{D-1} for the rows r = rows[b], b >= 1, written to blocks[b] and w[r]:
// L(r, k) is blocks[b] itself (source == nullptr) or source_blocks[source[b]] (zero where that is
// kNoIndex).
template <int D>
void reflectRows(const RowReflections<D>& h, const Eigen::Matrix<double, D, D>* source_blocks,
                 const Index* source, Eigen::Matrix<double, D, D>* blocks, const Index* rows,
                 Index size, Eigen::Matrix<double, D, D>* w) {
  if constexpr (D == 3) {
    if (detail::cpuHasAvxFma()) {
      if (source == nullptr) {
        detail::applyRowReflectionsAvx(h.u, h.beta, blocks, rows, size, w);
      } else {
        detail::applyRowReflectionsFromAvx(h.u, h.beta, source_blocks, source, blocks, rows, size,
                                           w);
      }
      return;
    }
  }
  for (Index b = 1; b < size; ++b) {
    if (source != nullptr) {
      if (source[b] != kNoIndex) {
        blocks[b] = source_blocks[source[b]];
      } else {
        blocks[b].setZero();
      }
    }
    h.apply(blocks[b], w[rows[b]]);
  }
}

// Returns false if a diagonal entry of l' is not positive and finite (w and l together do not
// have full rank).
template <int D>
bool triangularizeRows(const Eigen::Matrix<double, D, D>& l, const Eigen::Matrix<double, D, D>& w,
                       Eigen::Matrix<double, D, D>& l_new, RowReflections<D>& h) {
  Eigen::Matrix<double, D, D> m_l = l;
  Eigen::Matrix<double, D, D> m_w = w;
  for (int j = 0; j < D; ++j) {
    const double alpha = m_l(j, j);
    const double sigma = m_w.row(j).squaredNorm();
    const double norm = std::sqrt(alpha * alpha + sigma);
    if (!(norm > 0.0) || !std::isfinite(norm)) return false;
    if (sigma == 0.0 && alpha > 0.0) {  // row j is already in place: H_j = I
      h.beta(j) = 0.0;
      h.u.col(j).setZero();
      continue;
    }
    // v = x - norm e_j, scaled so that v(j) = 1; for alpha > 0 the difference is formed as
    // -sigma / (alpha + norm), which does not cancel.
    const double v0 = alpha <= 0.0 ? alpha - norm : -sigma / (alpha + norm);
    h.beta(j) = 2.0 * v0 * v0 / (sigma + v0 * v0);
    h.u.col(j) = m_w.row(j).transpose() / v0;
    // Rows j .. D-1 still to be reduced (rows above are final and zero in w).
    for (int r = j; r < D; ++r) {
      const double s = h.beta(j) * (m_l(r, j) + m_w.row(r).dot(h.u.col(j)));
      m_l(r, j) -= s;
      m_w.row(r) -= s * h.u.col(j).transpose();
    }
  }
  // What remains right of the diagonal is rounding of exact zeros.
  l_new = m_l.template triangularView<Eigen::Lower>();
  return true;
}

}  // namespace

template <int D>
Status IncrementalCholesky<D>::addFactorRows(const Index* positions, const Block* rows_transposed,
                                             Index count, const Vector& rhs) {
  LSLAM_ASSERT(in_update_ && !full_ && count > 0);
  if (row_update_mark_ == 0) row_update_mark_ = nextMark();
  // The factor's pattern, ascending, with its blocks in update_rows.
  Index* pattern = a_.scratch;
  for (Index i = 0; i < count; ++i) {
    const Index p = positions[i];
    LSLAM_ASSERT(p >= 0 && p < staged_columns_);
    Index j = i;
    while (j > 0 && pattern[j - 1] > p) {
      pattern[j] = pattern[j - 1];
      --j;
    }
    LSLAM_ASSERT(j == 0 || pattern[j - 1] != p);
    pattern[j] = p;
    a_.update_rows[p] = rows_transposed[i];
  }
  Vector b = rhs;
  const Index* rest = pattern;
  Index rest_size = count;
  // Column by column up the path: the rows still to absorb are always the structure of the
  // column just rotated, so its smallest row is the updated parent.
  while (rest_size > 0) {
    const Index k = rest[0];
    const Status s = rowUpdateColumn(k, rest + 1, rest_size - 1, b);
    if (s != Status::Ok) return s;
    rest = a_.rows + a_.staged_start[k] + 1;
    rest_size = a_.staged_count[k] - 1;
  }
  return Status::Ok;
}

// Rotates column k (its latest version: staged by this update, committed, or empty if added) with
// the update rows of k and of `pattern` (rows below k, ascending, their blocks in update_rows).
// Writes the updated column to the pool tail with structure old rows + pattern (or, when this
// update staged it already and its rows cover the pattern, where it is), and leaves the rows'
// transformed blocks in update_rows for the parent.
template <int D>
Status IncrementalCholesky<D>::rowUpdateColumn(Index k, const Index* pattern, Index pattern_size,
                                               Vector& rhs) {
  const bool staged = a_.mark[k] == row_update_mark_;
  const bool committed = !staged && k < n_;
  const Index old_start = staged ? a_.staged_start[k] : a_.start[k];
  const Index old_size = staged ? a_.staged_count[k] : (committed ? a_.count[k] : 0);
  Block l_old = Block::Zero();
  Vector d_old = Vector::Zero();
  if (staged) {
    l_old = a_.staged_diagonal[k];
    d_old = a_.staged_d[k];
  } else if (committed) {
    l_old = a_.diagonal[k];
    d_old = a_.d[k];
  }
  const Index* old_rows = a_.rows + old_start;
  // A column this update already staged, whose rows take in the pattern (a step's second loop
  // closure through the same top: the first one added the newest pose's row), is rotated where it
  // is: the staged copy is this update's own, and a rollback forgets it anyway. On city10000 that
  // is 44 % of the rotated blocks, which no longer go through a copy and a second staging.
  // Either way W(r) of its rows the pattern does not hold is zeroed now (the merge below would
  // zero the same rows), in the pass that checks the cover.
  const bool in_place = staged && zeroUnreachedRows(old_rows, old_size, pattern, pattern_size);
  // Worst case every pattern row is fill.
  if (!in_place && pool_end_ + (old_size > 0 ? old_size : 1) + pattern_size > a_.max_blocks) {
    return Status::CapacityExhausted;
  }
  Block l_new;
  RowReflections<D> h;
  if (!triangularizeRows<D>(l_old, a_.update_rows[k], l_new, h)) {
    return Status::NotPositiveDefinite;
  }

  const Index start = in_place ? old_start : pool_end_;
  Index* rows = a_.rows + start;
  Block* blocks = a_.blocks + start;
  Index size = old_size;
  if (in_place) {
    reflectRows<D>(h, nullptr, nullptr, blocks, rows, size, a_.update_rows);
  } else {
    // The merge decides the structure and where each block comes from; the reflections then read
    // the old blocks and write the staged ones in one pass (a copy to the staging area first, then
    // reflections there, took ~9 % of city10000's run in the copy alone). The merge's branching
    // stays in a loop of its own: inside it, the reflections ran ~20 % slower.
    Index* source = a_.row_list;
    size = mergeRows(k, old_rows, old_size, pattern, pattern_size, !staged, rows, source);
    reflectRows<D>(h, a_.blocks + old_start, source, blocks, rows, size, a_.update_rows);
  }
  // The D reflections per row block: D (2 D^2 + 2 D) multiply-adds, ~2.7 block products.
  const std::int64_t products = 3 * static_cast<std::int64_t>(size - 1);
  // The right-hand side is one more row: [d(k)^T b^T].
  Eigen::Matrix<double, 1, D> d_row = d_old.transpose();
  Eigen::Matrix<double, 1, D> b_row = rhs.transpose();
  h.apply(d_row, b_row);
  const Vector d_new = d_row.transpose();
  rhs = b_row.transpose();
  blocks[0] = detail::invertLowerTriangular<D>(l_new);
  if (!in_place) pool_end_ += size;
  if (!staged) {
    a_.mark[k] = row_update_mark_;
    a_.affected[affected_count_++] = k;
  }
  a_.staged_start[k] = start;
  a_.staged_count[k] = size;
  a_.staged_diagonal[k] = l_new;
  a_.staged_d[k] = d_new;
  stats_.block_products += products;
  return Status::Ok;
}

// W(r) = 0 for the rows r = rows[b], b >= 1, that the pattern (ascending) does not hold: the
// factor's rows have not reached them. Returns whether the rows hold every pattern row.
template <int D>
bool IncrementalCholesky<D>::zeroUnreachedRows(const Index* rows, Index size, const Index* pattern,
                                               Index pattern_size) {
  Index j = 0;
  bool covered = true;
  for (Index b = 1; b < size; ++b) {
    const Index r = rows[b];
    if (j < pattern_size && pattern[j] == r) {  // the common case on a dense top, tested first
      ++j;
      continue;
    }
    for (; j < pattern_size && pattern[j] < r; ++j) covered = false;
    if (j < pattern_size && pattern[j] == r) {
      ++j;
    } else {
      a_.update_rows[r].setZero();
    }
  }
  return covered && j == pattern_size;
}

// Writes column k's structure, its old rows (from 1) merged with the pattern (both ascending), to
// rows, and for each row where its block L(r, k) comes from to source: the old block's place, or
// kNoIndex for fill (zero). With zero_unreached, W(r) is set to zero for the old rows the pattern
// does not hold, which the factor's rows have not reached yet (otherwise zeroUnreachedRows did).
// Returns the column's size.
template <int D>
Index IncrementalCholesky<D>::mergeRows(Index k, const Index* old_rows, Index old_size,
                                        const Index* pattern, Index pattern_size,
                                        bool zero_unreached, Index* rows, Index* source) {
  rows[0] = k;
  Index size = 1;
  Index i = 1;
  Index j = 0;
  // One step per row of the result, the common case first: on a dense top the two lists are
  // nearly the same, so most steps take a row both hold (a predictable branch; a loop over the
  // pattern with an inner loop over old rows took ~37 instructions per row on city10000).
  while (i < old_size && j < pattern_size) {
    const Index old_row = old_rows[i];
    const Index pattern_row = pattern[j];
    if (old_row == pattern_row) {
      rows[size] = old_row;
      source[size] = i++;
      ++j;
    } else if (old_row < pattern_row) {
      rows[size] = old_row;
      source[size] = i++;
      if (zero_unreached) a_.update_rows[old_row].setZero();
    } else {
      rows[size] = pattern_row;
      source[size] = kNoIndex;
      ++j;
    }
    ++size;
  }
  for (; i < old_size; ++i, ++size) {
    rows[size] = old_rows[i];
    source[size] = i;
    if (zero_unreached) a_.update_rows[old_rows[i]].setZero();
  }
  for (; j < pattern_size; ++j, ++size) {
    rows[size] = pattern[j];
    source[size] = kNoIndex;
  }
  return size;
}

template <int D>
Status IncrementalCholesky<D>::finishRowUpdate() {
  LSLAM_ASSERT(in_update_ && !full_);
  for (Index k = n_; k < staged_columns_; ++k) {
    if (row_update_mark_ == 0 || a_.mark[k] != row_update_mark_) {
      return Status::NotPositiveDefinite;  // an added column no factor reached has no pivot
    }
  }
  stats_.columns_recomputed = affected_count_;
  stats_.blocks_written = pool_end_ - pool_mark_;
  return Status::Ok;
}

#define LSLAM_INSTANTIATE_ROW_UPDATE(D)                                                         \
  template Status IncrementalCholesky<D>::addFactorRows(const Index*, const Block*, Index,      \
                                                        const Vector&);                         \
  template Status IncrementalCholesky<D>::rowUpdateColumn(Index, const Index*, Index, Vector&); \
  template bool IncrementalCholesky<D>::zeroUnreachedRows(const Index*, Index, const Index*,    \
                                                          Index);                               \
  template Index IncrementalCholesky<D>::mergeRows(Index, const Index*, Index, const Index*,    \
                                                   Index, bool, Index*, Index*);                \
  template Status IncrementalCholesky<D>::finishRowUpdate();
LSLAM_INSTANTIATE_ROW_UPDATE(2)
LSLAM_INSTANTIATE_ROW_UPDATE(3)
LSLAM_INSTANTIATE_ROW_UPDATE(6)
#undef LSLAM_INSTANTIATE_ROW_UPDATE

}  // namespace lslam
