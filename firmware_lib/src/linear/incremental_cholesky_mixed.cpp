// The numeric steps of IncrementalCholesky for mixed block sizes (block_sizes.h): the same steps as
// the one-size forms in incremental_cholesky.cpp and _reorder.cpp, on blocks of size(row) x
// width(column) addressed through their slot offsets. Each size is made a compile-time constant
// by withSize(), so every product is a fixed-size Eigen product.
#include <cmath>
#include <cstring>

#include "lower_triangular.h"
#include "lslam/linear/incremental_cholesky.h"

namespace lslam {
namespace {

template <int R, int C>
using MatrixMap = Eigen::Map<Eigen::Matrix<double, R, C>>;
template <int R, int C>
using ConstMatrixMap = Eigen::Map<const Eigen::Matrix<double, R, C>>;

}  // namespace

template <int... S>
Index IncrementalCholesky<S...>::columnValues(Index start, Index count) const {
  Index height = 0;
  for (Index i = 0; i < count; ++i) height += slotSize(start + i);
  return height * slotSize(start);
}

// As the one-size startColumn: zero, then the old C(:,k) = L_old(:,k) L_old(k,k)^T, then the
// change of Lambda.
template <int... S>
void IncrementalCholesky<S...>::startMixedColumn(Index k, const InformationSource<S...>& source,
                                                 const Index* variable_at,
                                                 const Index* position_of) {
  const Index start = a_.staged_start[k];
  const Index size = a_.staged_count[k];
  const Index* rows = a_.rows + start;
  for (Index i = 0; i < size; ++i) a_.slot[rows[i]] = i;
  // A staged column's values are contiguous, in slot order, from its first slot's offset.
  std::memset(slotValues(start), 0,
              sizeof(double) * static_cast<std::size_t>(columnValues(start, size)));
  Vector& e = a_.staged_d[k];
  e.setZero();
  if (!reordered_ && k < n_) {
    withSize<S...>(slotSize(start), [&](auto width) {
      constexpr int C = decltype(width)::value;
      const Eigen::Matrix<double, C, C> l = a_.diagonal[k].template topLeftCorner<C, C>();
      const Eigen::Matrix<double, C, C> l_t = l.transpose();
      const Index old_start = a_.start[k];
      const Index* old_rows = a_.rows + old_start;
      MatrixMap<C, C>(slotValues(start)).noalias() = l * l_t;
      for (Index i = 1; i < a_.count[k]; ++i) {
        withSize<S...>(slotSize(old_start + i), [&](auto height) {
          constexpr int R = decltype(height)::value;
          MatrixMap<R, C>(slotValues(start + a_.slot[old_rows[i]])).noalias() =
              ConstMatrixMap<R, C>(slotValues(old_start + i)) * l_t;
        });
      }
      e.template head<C>().noalias() = l * a_.d[k].template head<C>();
    });
  }
  ColumnAccumulator<S...> acc(a_.values, a_.offset + start, a_.slot, &e);
  source.assembleColumnChange(variable_at[k], position_of, acc);
}

// As the one-size assembleAllColumns' body for one column.
template <int... S>
void IncrementalCholesky<S...>::assembleMixedColumn(Index k, const InformationSource<S...>& source,
                                                    const Index* variable_at,
                                                    const Index* position_of,
                                                    LaterDiagonals<S...>& later) {
  const Index start = a_.staged_start[k];
  const Index size = a_.staged_count[k];
  const Index* rows = a_.rows + start;
  const int width = slotSize(start);
  withSize<S...>(width, [&](auto w) {
    constexpr int C = decltype(w)::value;
    MatrixMap<C, C>(slotValues(start)) = a_.staged_diagonal[k].template topLeftCorner<C, C>();
  });
  std::memset(slotValues(start) + width * width, 0,
              sizeof(double) * static_cast<std::size_t>(columnValues(start, size) - width * width));
  for (Index b = 1; b < size; ++b) a_.slot[rows[b]] = b;
  ColumnAccumulator<S...> acc(a_.values, a_.offset + start, a_.slot, &a_.staged_d[k]);
  source.assembleColumn(variable_at[k], position_of, acc, later);
}

template <int... S>
Status IncrementalCholesky<S...>::finishMixedColumn(Index k) {
  const Index start = a_.staged_start[k];
  const Index size = a_.staged_count[k];
  Status status = Status::Ok;
  withSize<S...>(slotSize(start), [&](auto width) {
    constexpr int C = decltype(width)::value;
    using Square = Eigen::Matrix<double, C, C>;
    MatrixMap<C, C> diagonal(slotValues(start));
    Square l;
    Square l_inv;
    if (!detail::invertedCholesky<C>(Square(diagonal), l, l_inv)) {
      status = Status::NotPositiveDefinite;
      return;
    }
    a_.staged_diagonal[k].setZero();
    a_.staged_diagonal[k].template topLeftCorner<C, C>() = l;
    diagonal = l_inv;
    // L(:,k) = C(:,k) L(k,k)^-T.
    const Square l_inv_t = l_inv.transpose();
    for (Index i = 1; i < size; ++i) {
      withSize<S...>(slotSize(start + i), [&](auto height) {
        constexpr int R = decltype(height)::value;
        MatrixMap<R, C> block(slotValues(start + i));
        block = (block * l_inv_t).eval();
      });
    }
    auto d = a_.staged_d[k].template head<C>();
    d = (l_inv * d).eval();
    // As for one size: finite pivots do not make a finite right-hand side.
    if (!d.allFinite()) status = Status::NumericalOverflow;
  });
  return status;
}

// Column j's contribution -/+ L(r,j) L(s,j)^T (and -/+ L(s,j) d(j)) to every column s of its
// structure, as the one-size scatter.
template <int... S>
void IncrementalCholesky<S...>::scatterMixed(Index start, Index size, const Vector& d,
                                             double sign) {
  const Index* rows = a_.rows + start;
  withSize<S...>(slotSize(start), [&](auto width) {
    constexpr int C = decltype(width)::value;
    for (Index a = 1; a < size; ++a) {
      const Index s = rows[a];
      const Index target_start = a_.staged_start[s];
      const Index* target_rows = a_.rows + target_start;
      withSize<S...>(slotSize(start + a), [&](auto height_a) {
        constexpr int RA = decltype(height_a)::value;
        const ConstMatrixMap<RA, C> l_sj(slotValues(start + a));
        // sign * L(s,j), transposed in the products below.
        Eigen::Matrix<double, RA, C> scaled;
        scaled.noalias() = sign * l_sj;
        const auto l_sj_t = scaled.transpose();
        a_.staged_d[s].template head<RA>().noalias() += scaled * d.template head<C>();
        MatrixMap<RA, RA>(slotValues(target_start)).noalias() += l_sj * l_sj_t;
        Index p = 1;
        for (Index b = a + 1; b < size; ++b) {
          while (target_rows[p] < rows[b]) ++p;
          LSLAM_DEBUG_ASSERT(p < a_.staged_count[s] && target_rows[p] == rows[b]);
          withSize<S...>(slotSize(start + b), [&](auto height_b) {
            constexpr int RB = decltype(height_b)::value;
            MatrixMap<RB, RA>(slotValues(target_start + p)).noalias() +=
                ConstMatrixMap<RB, C>(slotValues(start + b)) * l_sj_t;
          });
        }
      });
      stats_.block_products += size - a;
    }
  });
}

// x(k) = L(k,k)^-T (d(k) - sum_{i >= 1} L(r_i,k)^T x(r_i)), as detail::solveColumnInPlace.
template <int... S>
bool IncrementalCholesky<S...>::solveMixedColumn(Index k, double tolerance, Vector& delta) {
  constexpr Index kStride = detail::kSolutionStride<D>;
  const Index start = a_.start[k];
  const Index size = a_.count[k];
  const Index* rows = a_.rows + start;
  bool moved = false;
  withSize<S...>(slotSize(start), [&](auto width) {
    constexpr int C = decltype(width)::value;
    Eigen::Matrix<double, C, 1> x = a_.d[k].template head<C>();
    for (Index i = 1; i < size; ++i) {
      withSize<S...>(slotSize(start + i), [&](auto height) {
        constexpr int R = decltype(height)::value;
        x.noalias() -= ConstMatrixMap<R, C>(slotValues(start + i)).transpose() *
                       ConstMatrixMap<R, 1>(a_.solution + kStride * rows[i]);
      });
    }
    const Eigen::Matrix<double, C, 1> solved =
        ConstMatrixMap<C, C>(slotValues(start)).transpose() * x;
    MatrixMap<C, 1> entry(a_.solution + kStride * k);
    moved = (solved - entry).cwiseAbs().maxCoeff() > tolerance;
    entry = solved;
    delta.template head<C>() = solved;
  });
  return moved;
}

// For addOldClique (either layout): old column j's share of the Schur complement on the reordered
// top, L(:,j) L(:,j)^T and L(:,j) d(j), its members taken in `order` (ascending reordered
// position).
template <int... S>
void IncrementalCholesky<S...>::addMembersOfOldClique(Index j, const Index* order) {
  const Index start = a_.start[j];
  const Index size = a_.count[j];
  const Index* rows = a_.rows + start;
  const Index* new_position = a_.new_position;
  withSize<S...>(slotSize(start), [&](auto width) {
    constexpr int C = decltype(width)::value;
    // The pool holds L(j,j)^-1; the Schur complement needs L(j,j) itself.
    const Eigen::Matrix<double, C, C> l_jj = a_.diagonal[j].template topLeftCorner<C, C>();
    const auto dj = a_.d[j].template head<C>();
    for (Index a = 0; a < size; ++a) {
      const Index ia = order[a];
      const Index target_column = new_position[rows[ia]];
      const Index target_start = a_.staged_start[target_column];
      const Index* target_rows = a_.rows + target_start;
      withSize<S...>(slotSize(start + ia), [&](auto height_a) {
        constexpr int RA = decltype(height_a)::value;
        const Eigen::Matrix<double, RA, C> m_a = member<RA, C>(l_jj, start, ia);
        const Eigen::Matrix<double, C, RA> m_a_t = m_a.transpose();
        a_.staged_d[target_column].template head<RA>().noalias() += m_a * dj;
        MatrixMap<RA, RA>(slotValues(target_start)).noalias() += m_a * m_a_t;
        Index p = 1;
        for (Index b = a + 1; b < size; ++b) {
          const Index ib = order[b];
          const Index row = new_position[rows[ib]];
          while (target_rows[p] < row) ++p;
          LSLAM_DEBUG_ASSERT(p < a_.staged_count[target_column] && target_rows[p] == row);
          withSize<S...>(slotSize(start + ib), [&](auto height_b) {
            constexpr int RB = decltype(height_b)::value;
            const Eigen::Matrix<double, RB, C> m_b = member<RB, C>(l_jj, start, ib);
            MatrixMap<RB, RA>(slotValues(target_start + p)).noalias() += m_b * m_a_t;
          });
        }
      });
    }
  });
  stats_.block_products += static_cast<std::int64_t>(size) * (size + 1) / 2;
}

// Block i of the old column at `start`: L(j,j) itself for i == 0 (the pool holds its inverse).
template <int... S>
template <int R, int C>
Eigen::Matrix<double, R, C> IncrementalCholesky<S...>::member(
    const Eigen::Matrix<double, C, C>& l_jj, Index start, Index i) const {
  if constexpr (R == C) {
    if (i == 0) return l_jj;
  }
  return ConstMatrixMap<R, C>(slotValues(start + i));
}

template <int... S>
Index IncrementalCholesky<S...>::moveColumn(Index from, Index count, PoolEnd write) {
  // The column's values: one range, from its lowest offset (its slots may point into it in any
  // order after a reordered commit), read before the slots move.
  Index base = a_.offset[from];
  for (Index i = 1; i < count; ++i) base = a_.offset[from + i] < base ? a_.offset[from + i] : base;
  const Index length = columnValues(from, count);
  if (from != write.blocks) {
    std::memmove(a_.rows + write.blocks, a_.rows + from,
                 sizeof(Index) * static_cast<std::size_t>(count));
    std::memmove(a_.row_size + write.blocks, a_.row_size + from, static_cast<std::size_t>(count));
  }
  // Ascending: write.blocks <= from, so no offset is overwritten before it is read.
  for (Index i = 0; i < count; ++i)
    a_.offset[write.blocks + i] = a_.offset[from + i] - base + write.values;
  if (base != write.values) {
    std::memmove(a_.values + write.values, a_.values + base,
                 sizeof(double) * static_cast<std::size_t>(length));
  }
  return write.values + length;
}

template <int... S>
void IncrementalCholesky<S...>::copyColumnValues(Index from, Index count, Index to) {
  if constexpr (kUniform) {
    for (Index b = 0; b < count; ++b) a_.blocks[to + b] = a_.blocks[from + b];
  } else {
    const int width = slotSize(from);
    for (Index b = 0; b < count; ++b) {
      LSLAM_DEBUG_ASSERT(slotSize(from + b) == slotSize(to + b));
      std::memcpy(slotValues(to + b), slotValues(from + b),
                  sizeof(double) * static_cast<std::size_t>(slotSize(from + b) * width));
    }
  }
}

#define LSLAM_INSTANTIATE_EITHER(...)                                                    \
  template void IncrementalCholesky<__VA_ARGS__>::copyColumnValues(Index, Index, Index); \
  template void IncrementalCholesky<__VA_ARGS__>::addMembersOfOldClique(Index, const Index*);
LSLAM_INSTANTIATE_EITHER(2)
LSLAM_INSTANTIATE_EITHER(3)
LSLAM_INSTANTIATE_EITHER(6)
LSLAM_INSTANTIATE_EITHER(3, 2)
LSLAM_INSTANTIATE_EITHER(6, 3)
#undef LSLAM_INSTANTIATE_EITHER

#define LSLAM_INSTANTIATE_MIXED(...)                                                        \
  template Index IncrementalCholesky<__VA_ARGS__>::columnValues(Index, Index) const;        \
  template void IncrementalCholesky<__VA_ARGS__>::startMixedColumn(                         \
      Index, const InformationSource<__VA_ARGS__>&, const Index*, const Index*);            \
  template void IncrementalCholesky<__VA_ARGS__>::assembleMixedColumn(                      \
      Index, const InformationSource<__VA_ARGS__>&, const Index*, const Index*,             \
      LaterDiagonals<__VA_ARGS__>&);                                                        \
  template Status IncrementalCholesky<__VA_ARGS__>::finishMixedColumn(Index);               \
  template void IncrementalCholesky<__VA_ARGS__>::scatterMixed(Index, Index, const Vector&, \
                                                               double);                     \
  template bool IncrementalCholesky<__VA_ARGS__>::solveMixedColumn(Index, double, Vector&); \
  template Index IncrementalCholesky<__VA_ARGS__>::moveColumn(Index, Index, PoolEnd);
LSLAM_INSTANTIATE_MIXED(3, 2)
LSLAM_INSTANTIATE_MIXED(6, 3)
#undef LSLAM_INSTANTIATE_MIXED

}  // namespace lslam
