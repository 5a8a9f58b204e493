// The row update of IncrementalCholesky: L L^T + A^T A for the whitened rows A of an added factor,
// by orthogonal transformations of [L(:,k) A(:,k)^T] along the etree path (see the header).
//
// Why it is cheap: adding a factor between an old pose i and the newest pose changes exactly the
// columns on the (updated) etree path from i to the root. factorize() recomputes each of them
// from its old value, sending every updated-minus-old outer product L(r,k) L(s,k)^T to the
// columns of its structure: s^2 block products for a column of structure s. Here column k and
// the factor's rows are rotated together, [L(:,k) W(:,k)] Q = [L'(:,k) W'(:,k)], and only W'
// travels on to the parent: about 3 s block products (Q kept as D reflections). On a dense top of
// ~100 columns that is ~10^4 products per loop closure instead of ~10^6. Orthogonal
// transformations also add no cancellation.
//
// The right-hand side rides along as one more row: L d = eta is the last row of the Cholesky
// factor of [Lambda eta; eta^T .], so [d(k)^T b^T] Q = [d'(k)^T b'^T] updates d on the same path.
#include <cmath>
#include <cstring>
#include <type_traits>

#include "lower_triangular.h"
#include "lslam/linear/block_kernels.h"
#include "lslam/linear/incremental_cholesky.h"

namespace lslam {
namespace {

// The C Householder reflections H_j = I - beta_j v_j v_j^T (C + M W square) with
// [l w_0 .. w_{M-1}] H_0 ... H_{C-1} = [l' 0 .. 0], l' lower-triangular with a positive diagonal,
// for l lower-triangular (C x C, possibly zero for an added column) and the M factors' blocks w_m
// (C x W each: a factor's W rows, zero beyond its own). H_j zeroes row j right of the diagonal
// (Golub & Van Loan 5.1.1, sign chosen so that the kept entry is +norm). Entries of row j right of
// the diagonal within l are still zero when H_j is formed (H_0 .. H_{j-1} only mix l's columns
// 0 .. j-1 with w), so v_j = e_j + [0; u_0j; ..]: applying H_j to a row costs 2 M W + 2
// multiply-adds, against 2 (C + M W) for the row times an explicit Q, which is why the reflections
// are kept in this factored form. One block size D: C = W = D. K: the kernels' multiply-add kind
// (detail::multiplyAdd; 0 for mixed sizes, which have no second form to match).
template <int C, int W, int M, int K = C>
struct RowReflections {
  Eigen::Matrix<double, W, C> u[M];  // u[m].col(j): factor m's part of v_j
  Eigen::Matrix<double, C, 1> beta;

  // [x_l x_w[0] ..] H_0 ... H_{C-1} for the rows of x_l (any count), in place.
  template <typename XL, typename XW>
  void apply(XL& x_l, XW* const* x_w) const {
    detail::applyReflectionsToRows<C, W, M, K>(u, beta, x_l, x_w);
  }
  // The same on one row (the right-hand side's), through the AVX2/FMA-compiled form on hosts that
  // have it: outside such a function std::fma is a call into libm on x86-64. The same bits.
  template <typename XW>
  void applyToRow(Eigen::Matrix<double, 1, C>& x_l, XW* const* x_w) const {
    if constexpr (C == W && K == C && detail::kAvxForms<C>) {
      if (detail::cpuHasAvxFma()) {
        detail::applyRowReflectionsToRowAvx<M>(u, beta, x_l, x_w);
        return;
      }
    }
    apply(x_l, x_w);
  }
};

// L(r, k) for the rows r = rows[b], b >= 1, written to blocks[b]: source_blocks[b] for b < kept,
// source_blocks[source[b]] beyond, zero where that is kNoIndex. In place: source_blocks == blocks,
// kept == size.
template <int D>
void stageRows(const Eigen::Matrix<double, D, D>* source_blocks, const Index* source, Index kept,
               Eigen::Matrix<double, D, D>* blocks, Index b) {
  if (b < kept) {
    if (source_blocks != blocks) blocks[b] = source_blocks[b];
  } else if (source[b] != kNoIndex) {
    blocks[b] = source_blocks[source[b]];
  } else {
    blocks[b].setZero();
  }
}

// Nothing to compute ahead of the reflections (block sizes other than 6).
struct NoOverlaps {
  explicit NoOverlaps(const void*) {}
};

// [L(r, k) W_0(r) ..] H_0 ... H_{D-1} for the rows r = rows[b], b >= 1, written to blocks[b] and
// w[m][r], L(r, k) read as stageRows says. At D = 6 in the compact form
// (detail::applyCompactReflections6), its overlaps computed once for the column.
template <int D, int M>
void reflectRows(const RowReflections<D, D, M>& h, const Eigen::Matrix<double, D, D>* source_blocks,
                 const Index* source, Index kept, Eigen::Matrix<double, D, D>* blocks,
                 const Index* rows, Index size, Eigen::Matrix<double, D, D>* const* w) {
  if constexpr (detail::kAvxForms<D>) {
    if (detail::cpuHasAvxFma()) {
      detail::applyRowReflectionsFromAvx<M>(h.u, h.beta, source_blocks, source, kept, blocks, rows,
                                            size, w);
      return;
    }
  }
  using Overlaps = std::conditional_t<D == 6, detail::ReflectionOverlaps6<M>, NoOverlaps>;
  const Overlaps overlaps(h.u);
  for (Index b = 1; b < size; ++b) {
    stageRows<D>(source_blocks, source, kept, blocks, b);
    Eigen::Matrix<double, D, D>* x_w[M];
    for (int m = 0; m < M; ++m) x_w[m] = &w[m][rows[b]];
    if constexpr (D == 6) {
      detail::applyCompactReflections6<M>(h.u, h.beta, overlaps, blocks[b], x_w);
    } else {
      h.apply(blocks[b], x_w);
    }
  }
}

// Returns false if a diagonal entry of l' is not positive and finite (w and l together do not
// have full rank). Works on w in place.
template <int C, int W, int M, int K>
bool triangularizeRows(const Eigen::Matrix<double, C, C>& l, Eigen::Matrix<double, C, W>* m_w,
                       Eigen::Matrix<double, C, C>& l_new, RowReflections<C, W, M, K>& h) {
  Eigen::Matrix<double, C, C> m_l = l;
  for (int j = 0; j < C; ++j) {
    const double alpha = m_l(j, j);
    double sigma = m_w[0].row(j).squaredNorm();
    for (int m = 1; m < M; ++m) sigma += m_w[m].row(j).squaredNorm();
    const double norm = std::sqrt(alpha * alpha + sigma);
    if (!(norm > 0.0) || !std::isfinite(norm)) return false;
    if (sigma == 0.0 && alpha > 0.0) {  // row j is already in place: H_j = I
      h.beta(j) = 0.0;
      for (int m = 0; m < M; ++m) h.u[m].col(j).setZero();
      continue;
    }
    // v = x - norm e_j, scaled so that v(j) = 1; for alpha > 0 the difference is formed as
    // -sigma / (alpha + norm), which does not cancel.
    const double v0 = alpha <= 0.0 ? alpha - norm : -sigma / (alpha + norm);
    h.beta(j) = 2.0 * v0 * v0 / (sigma + v0 * v0);
    for (int m = 0; m < M; ++m) h.u[m].col(j) = m_w[m].row(j).transpose() / v0;
    // Rows j .. C-1 still to be reduced (rows above are final and zero in w).
    for (int r = j; r < C; ++r) {
      double dot = m_w[0].row(r).dot(h.u[0].col(j));
      for (int m = 1; m < M; ++m) dot += m_w[m].row(r).dot(h.u[m].col(j));
      const double s = h.beta(j) * (m_l(r, j) + dot);
      m_l(r, j) -= s;
      for (int m = 0; m < M; ++m) m_w[m].row(r) -= s * h.u[m].col(j).transpose();
    }
  }
  // What remains right of the diagonal is rounding of exact zeros.
  l_new = m_l.template triangularView<Eigen::Lower>();
  return true;
}

// The right-hand side is one more row, [d(k)^T b_0^T ..], rotated by h: d(k) to d_new, each
// factor's b on to the parent in rhs. False if d_new is not finite (as in finishColumn).
template <int M, class Reflections, int C, int D>
bool rotateRightHandSide(const Reflections& h, const Eigen::Matrix<double, C, 1>& d,
                         Eigen::Matrix<double, D, 1>* rhs, Eigen::Matrix<double, C, 1>& d_new) {
  Eigen::Matrix<double, 1, C> d_row = d.transpose();
  Eigen::Matrix<double, 1, D> b_rows[M];
  Eigen::Matrix<double, 1, D>* b_row_of[M];
  for (int m = 0; m < M; ++m) {
    b_rows[m] = rhs[m].transpose();
    b_row_of[m] = &b_rows[m];
  }
  h.applyToRow(d_row, b_row_of);
  if (!d_row.allFinite()) return false;
  for (int m = 0; m < M; ++m) rhs[m] = b_rows[m].transpose();
  d_new = d_row.transpose();
  return true;
}

}  // namespace

// The factor's column positions, ascending, to `pattern`, with its blocks in w.
template <int... S>
void IncrementalCholesky<S...>::loadFactorRows(const FactorRows& factor, Index* pattern, Block* w) {
  for (Index i = 0; i < factor.count; ++i) {
    const Index p = factor.positions[i];
    LSLAM_ASSERT(p >= 0 && p < staged_columns_);
    Index j = i;
    while (j > 0 && pattern[j - 1] > p) {
      pattern[j] = pattern[j - 1];
      --j;
    }
    LSLAM_ASSERT(j == 0 || pattern[j - 1] != p);
    pattern[j] = p;
    w[p] = factor.rows_transposed[i];
  }
}

template <int... S>
Status IncrementalCholesky<S...>::addFactorRows(const FactorRows& factor) {
  LSLAM_ASSERT(in_update_ && !full_ && factor.count > 0);
  if (row_update_mark_ == 0) row_update_mark_ = nextMark();
  Index* pattern = a_.scratch;
  loadFactorRows(factor, pattern, a_.update_rows[0]);
  Block* const w[1] = {a_.update_rows[0]};
  Vector rhs[1] = {factor.rhs};
  return rotateToRoot<1>(pattern, factor.count, w, rhs);
}

template <int... S>
Status IncrementalCholesky<S...>::addFactorRows(const FactorRows& first, const FactorRows& second) {
  const FactorRows* const factors[2] = {&first, &second};
  return addFactorRows(factors, 2);
}

// Each factor starts as a group of its own. The group whose next column is the lowest goes first:
// every other group's path lies above that column, so never reaches it, and each column is
// rotated once. Groups whose next column is the same have met: their rows are united and from
// there on they are one group, whose rotations read, reflect and stage each block of the shared
// path once (about 1.6x the work of one factor's pass for two factors, instead of 2x, plus one
// column setup instead of two). A step's loop closures often meet low in the dense top.
template <int... S>
Status IncrementalCholesky<S...>::addFactorRows(const FactorRows* const* factors, int count) {
  LSLAM_ASSERT(in_update_ && !full_ && count > 0 && count <= kJointFactors);
  if (row_update_mark_ == 0) row_update_mark_ = nextMark();
  RowGroup groups[kJointFactors];
  Index* pattern = a_.scratch;
  for (int m = 0; m < count; ++m) {
    LSLAM_ASSERT(factors[m]->count > 0);
    loadFactorRows(*factors[m], pattern, a_.update_rows[m]);
    groups[m].rest = pattern;
    groups[m].size = factors[m]->count;
    groups[m].count = 1;
    groups[m].w[0] = a_.update_rows[m];
    groups[m].rhs[0] = factors[m]->rhs;
    pattern += factors[m]->count;
  }
  int live = count;  // groups[0 .. live) have columns left (a path may end at a root of a forest)
  while (live > 0) {
    int lowest = 0;
    for (int g = 1; g < live; ++g) {
      if (groups[g].rest[0] < groups[lowest].rest[0]) lowest = g;
    }
    RowGroup* meeting[kJointFactors] = {&groups[lowest]};
    int met = 1;
    for (int g = 0; g < live; ++g) {
      if (g != lowest && groups[g].rest[0] == groups[lowest].rest[0]) meeting[met++] = &groups[g];
    }
    // The united rows go to top_order, which the rotation below leaves at once for the column's
    // structure, so no other group's rest is ever there.
    if (met > 1) uniteGroups(meeting, met, a_.top_order);
    const Status s = rotateGroupColumn(groups[lowest]);
    if (s != Status::Ok) return s;
    // Groups merged into another (uniteGroups empties them) or at their root leave the list.
    for (int g = live - 1; g >= 0; --g) {
      if (groups[g].size == 0) groups[g] = groups[--live];
    }
  }
  return Status::Ok;
}

// Rotates the group's next column with its factors' rows (rotateNextColumn at its factor count).
template <int... S>
Status IncrementalCholesky<S...>::rotateGroupColumn(RowGroup& group) {
  switch (group.count) {
    case 1:
      return rotateNextColumn<1>(group.rest, group.size, group.w, group.rhs);
    default:
      if constexpr (kJointFactors == 3) {
        if (group.count == 3)
          return rotateNextColumn<3>(group.rest, group.size, group.w, group.rhs);
      }
      LSLAM_ASSERT(group.count == 2);
      return rotateNextColumn<2>(group.rest, group.size, group.w, group.rhs);
  }
}

// The union of the groups' ascending row lists (they start at the same column) to `united`; the
// first group takes it and the other groups' factors, which leave their groups empty (size 0). A
// row some group does not hold has not been reached by that group's factors: their W there is set
// to zero.
template <int... S>
void IncrementalCholesky<S...>::uniteGroups(RowGroup* const* groups, int count, Index* united) {
  static_assert(kJointFactors <= 3, "rotateGroupColumn dispatches up to three factors");
  Index next[kJointFactors] = {};
  Index size = 0;
  for (;;) {
    Index row = kNoIndex;
    for (int g = 0; g < count; ++g) {
      if (next[g] < groups[g]->size && (row == kNoIndex || groups[g]->rest[next[g]] < row)) {
        row = groups[g]->rest[next[g]];
      }
    }
    if (row == kNoIndex) break;
    for (int g = 0; g < count; ++g) {
      if (next[g] < groups[g]->size && groups[g]->rest[next[g]] == row) {
        ++next[g];
      } else {
        for (int m = 0; m < groups[g]->count; ++m) groups[g]->w[m][row].setZero();
      }
    }
    united[size++] = row;
  }
  RowGroup& into = *groups[0];
  for (int g = 1; g < count; ++g) {
    for (int m = 0; m < groups[g]->count; ++m) {
      LSLAM_ASSERT(into.count < kJointFactors);
      into.w[into.count] = groups[g]->w[m];
      into.rhs[into.count] = groups[g]->rhs[m];
      ++into.count;
    }
    groups[g]->size = 0;
  }
  into.rest = united;
  into.size = size;
}

// Rotates the columns from rest[0] up the path to its root (see rotateNextColumn).
template <int... S>
template <int M>
Status IncrementalCholesky<S...>::rotateToRoot(const Index* rest, Index rest_size, Block* const* w,
                                               Vector* rhs) {
  while (rest_size > 0) {
    const Status s = rotateNextColumn<M>(rest, rest_size, w, rhs);
    if (s != Status::Ok) return s;
  }
  return Status::Ok;
}

// Rotates the column rest[0] with the rows rest[1 ..] (see rowUpdateColumn), then moves rest on to
// that column's structure beyond it: the rows still to absorb, whose smallest is the updated
// parent.
template <int... S>
template <int M>
Status IncrementalCholesky<S...>::rotateNextColumn(const Index*& rest, Index& rest_size,
                                                   Block* const* w, Vector* rhs) {
  const Index k = rest[0];
  const Status s = rowUpdateColumn<M>(k, rest + 1, rest_size - 1, w, rhs);
  if (s != Status::Ok) return s;
  rest = a_.rows + a_.staged_start[k] + 1;
  rest_size = a_.staged_count[k] - 1;
  return Status::Ok;
}

// Rotates column k (its latest version: staged by this update, committed, or empty if added) with
// the update rows of M factors at k and at `pattern` (rows below k, ascending, their blocks in
// w[m]). Writes the updated column to the pool tail with structure old rows + pattern (or, when
// this update staged it already and its rows cover the pattern, where it is), and leaves the
// rows' transformed blocks in w for the parent.
template <int... S>
template <int M>
Status IncrementalCholesky<S...>::rowUpdateColumn(Index k, const Index* pattern, Index pattern_size,
                                                  Block* const* w, Vector* rhs) {
  if constexpr (!kUniform) {
    Status s = Status::Ok;
    withSize<S...>(positionSize(k), [&](auto width) {
      s = rowUpdateMixedColumn<decltype(width)::value, M>(k, pattern, pattern_size, w, rhs);
    });
    return s;
  } else {
    const LatestColumn<D> old = latestColumn<D>(k);
    const bool staged = old.staged;
    const Index old_start = old.start;
    const Index old_size = old.size;
    const Index* old_rows = a_.rows + old_start;
    // A column this update already staged, whose rows take in the pattern (a loop closure through
    // the columns an earlier factor of the step rotated: the odometry factor's, or a closure taken
    // alone), is rotated where it is: the staged copy is this update's own, and a rollback forgets
    // it anyway. Either way W(r) of its rows the pattern does not hold is zeroed now (the merge
    // below would zero the same rows), in the pass that checks the cover.
    const bool in_place =
        staged && zeroUnreachedRows<M>(old_rows, old_size, pattern, pattern_size, w);
    // Worst case every pattern row is fill.
    if (!in_place && pool_end_ + (old_size > 0 ? old_size : 1) + pattern_size > a_.max_blocks) {
      return Status::CapacityExhausted;
    }
    Block l_new;
    RowReflections<D, D, M> h;
    Block w_k[M];
    for (int m = 0; m < M; ++m) w_k[m] = w[m][k];
    bool full_rank = false;
    if constexpr (D == 6) {
      full_rank = detail::triangularizeRowsOfSix<M>(old.l, w_k, l_new, h.u, h.beta);
    } else {
      full_rank = triangularizeRows(old.l, w_k, l_new, h);
    }
    if (!full_rank) return Status::NotPositiveDefinite;

    const Index start = in_place ? old_start : pool_end_;
    Index* rows = a_.rows + start;
    Block* blocks = a_.blocks + start;
    Index size = old_size;
    if (in_place) {
      reflectRows<D, M>(h, blocks, nullptr, size, blocks, rows, size, w);
    } else {
      // The merge decides the structure and where each block comes from; the reflections then read
      // the old blocks and write the staged ones in one pass, with no copy to the staging area
      // first. The merge's branching stays in a loop of its own: inside, it would slow the
      // reflections.
      Index* source = a_.row_list;
      Index kept = 0;
      size = mergeRows<M>(k, old_rows, old_size, pattern, pattern_size, !staged, w, rows, source,
                          &kept);
      reflectRows<D, M>(h, a_.blocks + old_start, source, kept, blocks, rows, size, w);
    }
    // The D reflections per row block: about D (2 M D^2 + 2 D) multiply-adds (at D = 6 in the
    // compact form D (2 M D^2 + 27)), ~(2 M + 1) block products.
    const std::int64_t products = (2 * M + 1) * static_cast<std::int64_t>(size - 1);
    Vector d_new;
    if (!rotateRightHandSide<M>(h, old.d, rhs, d_new)) return Status::NumericalOverflow;
    // blocks[0], L(k,k)^-1 for the solve, is written once per column by finishRowUpdate: a loop
    // closure step rotates most of its path's columns two or three times.
    if (!in_place) pool_end_ += size;
    stageRotatedColumn<D>(k, staged, start, size, l_new, d_new);
    stats_.block_products += products;
    return Status::Ok;
  }
}

// rowUpdateColumn for mixed block sizes, column k of width C: the same steps on blocks of
// size(row) x C addressed through their slots (a staged column's values are contiguous, slot 0's
// first). The factors' rows are W = D wide, zero beyond a factor's own error rows, so the
// reflections run over D entries of each factor's rows whatever its error size.
template <int... S>
template <int C, int M>
Status IncrementalCholesky<S...>::rowUpdateMixedColumn(Index k, const Index* pattern,
                                                       Index pattern_size, Block* const* w,
                                                       Vector* rhs) {
  using Square = Eigen::Matrix<double, C, C>;
  const LatestColumn<C> old = latestColumn<C>(k);
  const bool staged = old.staged;
  const Index old_start = old.start;
  const Index old_size = old.size;
  const Index* old_rows = a_.rows + old_start;
  const bool in_place =
      staged && zeroUnreachedRows<M>(old_rows, old_size, pattern, pattern_size, w);
  if (!in_place && pool_end_ + (old_size > 0 ? old_size : 1) + pattern_size > a_.max_blocks) {
    return Status::CapacityExhausted;
  }
  Square l_new;
  RowReflections<C, D, M, 0> h;
  Eigen::Matrix<double, C, D> w_k[M];
  for (int m = 0; m < M; ++m) w_k[m] = w[m][k].template topRows<C>();
  if (!triangularizeRows(old.l, w_k, l_new, h)) return Status::NotPositiveDefinite;

  const Index start = in_place ? old_start : pool_end_;
  Index* rows = a_.rows + start;
  Index size = old_size;
  Index kept = old_size;
  const Index* source = a_.row_list;
  Index values = 0;
  if (!in_place) {
    size = mergeRows<M>(k, old_rows, old_size, pattern, pattern_size, !staged, w, rows, a_.row_list,
                        &kept);
    Index height = 0;
    for (Index b = 0; b < size; ++b) height += positionSize(rows[b]);
    values = height * C;
    if (value_end_ + values > a_.max_values) return Status::CapacityExhausted;
    Index offset = value_end_;
    for (Index b = 0; b < size; ++b) {
      const int row_size = positionSize(rows[b]);
      a_.row_size[start + b] = static_cast<std::uint8_t>(row_size);
      a_.offset[start + b] = offset;
      offset += row_size * C;
    }
  }
  for (Index b = 1; b < size; ++b) {
    const int height = slotSize(start + b);
    double* block = slotValues(start + b);
    if (!in_place) {
      const Index from = b < kept ? b : source[b];
      const std::size_t bytes = sizeof(double) * static_cast<std::size_t>(height * C);
      if (from != kNoIndex) {
        std::memcpy(block, slotValues(old_start + from), bytes);
      } else {
        std::memset(block, 0, bytes);
      }
    }
    Block* x_w[M];
    for (int m = 0; m < M; ++m) x_w[m] = &w[m][rows[b]];
    withSize<S...>(height, [&](auto rows_of_block) {
      Eigen::Map<Eigen::Matrix<double, decltype(rows_of_block)::value, C>> x_l(block);
      h.apply(x_l, x_w);
    });
  }
  // The reflections per row block: about (2 M + 1) block products, as for one size.
  const std::int64_t products = (2 * M + 1) * static_cast<std::int64_t>(size - 1);
  Eigen::Matrix<double, C, 1> d_new;
  if (!rotateRightHandSide<M>(h, old.d, rhs, d_new)) return Status::NumericalOverflow;
  Eigen::Map<Square>(slotValues(start)) = detail::invertLowerTriangular<C>(l_new);
  if (!in_place) {
    pool_end_ += size;
    value_end_ += values;
  }
  stageRotatedColumn<C>(k, staged, start, size, l_new, d_new);
  stats_.block_products += products;
  return Status::Ok;
}

// Column k's latest version: staged by this update, else committed, else none (an added column:
// no blocks, L(k,k) and d(k) zero), with the top-left C x C of its L(k,k) and C of its d(k).
template <int... S>
template <int C>
typename IncrementalCholesky<S...>::template LatestColumn<C>
IncrementalCholesky<S...>::latestColumn(Index k) const {
  LatestColumn<C> c;
  c.staged = a_.mark[k] == row_update_mark_;
  const bool committed = !c.staged && k < n_;
  c.start = c.staged ? a_.staged_start[k] : a_.start[k];
  c.size = c.staged ? a_.staged_count[k] : (committed ? a_.count[k] : 0);
  c.l.setZero();
  c.d.setZero();
  if (c.staged) {
    c.l = a_.staged_diagonal[k].template topLeftCorner<C, C>();
    c.d = a_.staged_d[k].template head<C>();
  } else if (committed) {
    c.l = a_.diagonal[k].template topLeftCorner<C, C>();
    c.d = a_.d[k].template head<C>();
  }
  return c;
}

// Records the rotated column k (its blocks staged at start) as this update's version.
template <int... S>
template <int C>
void IncrementalCholesky<S...>::stageRotatedColumn(Index k, bool staged, Index start, Index size,
                                                   const Eigen::Matrix<double, C, C>& l,
                                                   const Eigen::Matrix<double, C, 1>& d) {
  if (!staged) {
    a_.mark[k] = row_update_mark_;
    a_.affected[affected_count_++] = k;
  }
  a_.staged_start[k] = start;
  a_.staged_count[k] = size;
  a_.staged_diagonal[k].setZero();
  a_.staged_diagonal[k].template topLeftCorner<C, C>() = l;
  a_.staged_d[k].setZero();
  a_.staged_d[k].template head<C>() = d;
}

// W_m(r) = 0 for the rows r = rows[b], b >= 1, that the pattern (ascending) does not hold: the
// factor's rows have not reached them. Returns whether the rows hold every pattern row.
template <int... S>
template <int M>
bool IncrementalCholesky<S...>::zeroUnreachedRows(const Index* rows, Index size,
                                                  const Index* pattern, Index pattern_size,
                                                  Block* const* w) {
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
      for (int m = 0; m < M; ++m) w[m][r].setZero();
    }
  }
  return covered && j == pattern_size;
}

// Writes column k's structure, its old rows (from 1) merged with the pattern (both ascending), to
// rows, and for each row where its block L(r, k) comes from: the first `kept` rows (k's own
// included) are the old column's first rows, block b from old block b; beyond, source holds the
// old block's place, or kNoIndex for fill (zero). With zero_unreached, W_m(r) is set to zero for
// the old rows the pattern does not hold, which the factor's rows have not reached yet (otherwise
// zeroUnreachedRows did). Returns the column's size.
template <int... S>
template <int M>
Index IncrementalCholesky<S...>::mergeRows(Index k, const Index* old_rows, Index old_size,
                                           const Index* pattern, Index pattern_size,
                                           bool zero_unreached, Block* const* w, Index* rows,
                                           Index* source, Index* kept) {
  rows[0] = k;
  // The common case on a dense top: the pattern repeats the old rows, fill (if any) after them.
  // That run is only compared and copied, and its sources are implied: cheaper per row than the
  // merge below, with its two stores.
  Index j = 0;
  const Index common = old_size - 1 < pattern_size ? old_size - 1 : pattern_size;
  while (j < common && old_rows[j + 1] == pattern[j]) ++j;
  for (Index b = 1; b <= j; ++b) rows[b] = old_rows[b];
  Index size = j + 1;
  Index i = j + 1;
  *kept = size;
  // One step per row of the result, the common case first: on a dense top the two lists are
  // nearly the same, so most steps take a row both hold (a predictable branch).
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
      if (zero_unreached) {
        for (int m = 0; m < M; ++m) w[m][old_row].setZero();
      }
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
    if (zero_unreached) {
      for (int m = 0; m < M; ++m) w[m][old_rows[i]].setZero();
    }
  }
  for (; j < pattern_size; ++j, ++size) {
    rows[size] = pattern[j];
    source[size] = kNoIndex;
  }
  return size;
}

template <int... S>
Status IncrementalCholesky<S...>::finishRowUpdate() {
  LSLAM_ASSERT(in_update_ && !full_);
  for (Index k = n_; k < staged_columns_; ++k) {
    if (row_update_mark_ == 0 || a_.mark[k] != row_update_mark_) {
      return Status::NotPositiveDefinite;  // an added column no factor reached has no pivot
    }
  }
  if constexpr (kUniform) {
    for (Index i = 0; row_update_mark_ != 0 && i < affected_count_; ++i) {
      const Index k = a_.affected[i];
      if (a_.mark[k] == row_update_mark_) {
        a_.blocks[a_.staged_start[k]] = detail::invertLowerTriangular<D>(a_.staged_diagonal[k]);
      }
    }
  }
  stats_.columns_recomputed = affected_count_;
  stats_.blocks_written = pool_end_ - pool_mark_;
  return Status::Ok;
}

// The member templates (over M) are instantiated by their uses above; the plain members are
// instantiated here (only this file sees their definitions).
#define LSLAM_INSTANTIATE_ROW_UPDATE(...)                                                         \
  template void IncrementalCholesky<__VA_ARGS__>::loadFactorRows(const FactorRows&, Index*,       \
                                                                 Block*);                         \
  template Status IncrementalCholesky<__VA_ARGS__>::addFactorRows(const FactorRows&);             \
  template Status IncrementalCholesky<__VA_ARGS__>::addFactorRows(const FactorRows&,              \
                                                                  const FactorRows&);             \
  template Status IncrementalCholesky<__VA_ARGS__>::addFactorRows(const FactorRows* const*, int); \
  template Status IncrementalCholesky<__VA_ARGS__>::rotateGroupColumn(RowGroup&);                 \
  template void IncrementalCholesky<__VA_ARGS__>::uniteGroups(RowGroup* const*, int, Index*);     \
  template Status IncrementalCholesky<__VA_ARGS__>::finishRowUpdate();
LSLAM_INSTANTIATE_ROW_UPDATE(2)
LSLAM_INSTANTIATE_ROW_UPDATE(3)
LSLAM_INSTANTIATE_ROW_UPDATE(6)
LSLAM_INSTANTIATE_ROW_UPDATE(3, 2)
LSLAM_INSTANTIATE_ROW_UPDATE(6, 3)
#undef LSLAM_INSTANTIATE_ROW_UPDATE

}  // namespace lslam
