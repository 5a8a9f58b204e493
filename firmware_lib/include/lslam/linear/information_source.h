#pragma once
// The factorization never stores Lambda = J^T Omega J. It asks the factor graph for one column of
// it, linearized at the current points, when (and only when) that column of L is recomputed. So
// there is no Lambda to keep in sync, relinearizing a variable changes no stored matrix, and a
// rejected update has no Lambda to roll back.
#include "lslam/eigen.h"
#include "lslam/linear/block_sizes.h"
#include "lslam/linear/index.h"

namespace lslam {

// Receives the variables adjacent to one variable in the factor graph (repeats allowed).
class NeighbourVisitor {
 public:
  virtual void visit(Index variable) = 0;

 protected:
  ~NeighbourVisitor() = default;
};

// The adjacency of the variables in the factor graph: the pattern of Lambda.
class NeighbourGraph {
 public:
  // Calls visitor.visit(u) for every variable u sharing a factor with `variable`.
  virtual void visitNeighbours(Index variable, NeighbourVisitor& visitor) const = 0;

 protected:
  ~NeighbourGraph() = default;
};

// Receives the blocks of one column of Lambda and of eta, for rows addressed by column position.
// Blocks are size(row) x size(column) (see block_sizes.h); with one block size they are D x D
// blocks of an array, otherwise slices of the factor's value pool.
template <int... S>
class ColumnAccumulator {
 public:
  static constexpr int kMax = BlockSizes<S...>::kMax;
  using Block = Eigen::Matrix<double, kMax, kMax>;
  using Vector = Eigen::Matrix<double, kMax, 1>;

  // One block size: blocks[slot_of_row[row]] is the block of `row`.
  ColumnAccumulator(Block* blocks, const Index* slot_of_row, Vector* eta)
      : blocks_(blocks), slot_of_row_(slot_of_row), eta_(eta) {}
  // Mixed sizes: values + offset[slot_of_row[row]] is the block of `row` (offset[0]: diagonal).
  ColumnAccumulator(double* values, const Index* offset, const Index* slot_of_row, Vector* eta)
      : values_(values), offset_(offset), slot_of_row_(slot_of_row), eta_(eta) {}

  template <class Derived>
  void addDiagonal(const Eigen::MatrixBase<Derived>& block) {
    at<Derived>(0, block.rows(), block.cols()) += block;
  }
  // Lambda(row, column) for a row position after the column (its slot exists by construction).
  template <class Derived>
  void addBelow(Index row, const Eigen::MatrixBase<Derived>& block) {
    at<Derived>(slot_of_row_[row], block.rows(), block.cols()) += block;
  }
  template <class Derived>
  void addEta(const Eigen::MatrixBase<Derived>& v) {
    if constexpr (BlockSizes<S...>::kUniform) {
      *eta_ += v;
    } else {
      eta_->head(v.rows()) += v;
    }
  }

 private:
  // The block of a slot: one size, the array's block; mixed, the values at the slot's offset as a
  // matrix of the added block's size.
  template <class Derived>
  decltype(auto) at(Index slot, Eigen::Index rows, Eigen::Index cols) {
    if constexpr (BlockSizes<S...>::kUniform) {
      static_cast<void>(rows);
      static_cast<void>(cols);
      return (blocks_[slot]);
    } else {
      using Matrix = Eigen::Matrix<double, Derived::RowsAtCompileTime, Derived::ColsAtCompileTime>;
      return Eigen::Map<Matrix>(values_ + offset_[slot], rows, cols);
    }
  }

  Block* blocks_ = nullptr;
  double* values_ = nullptr;
  const Index* offset_ = nullptr;
  const Index* slot_of_row_;
  Vector* eta_;
};

// Receives, during a full factorization, the diagonal blocks and eta of columns after the one
// being assembled (see InformationSource::assembleColumn). Stored at the largest size; a column
// uses its top-left corner.
template <int... S>
class LaterDiagonals {
 public:
  static constexpr int kMax = BlockSizes<S...>::kMax;
  using Block = Eigen::Matrix<double, kMax, kMax>;
  using Vector = Eigen::Matrix<double, kMax, 1>;

  // Column p's diagonal block accumulates in diagonal_of_column[p], its eta in eta_of_column[p].
  LaterDiagonals(Block* diagonal_of_column, Vector* eta_of_column)
      : diagonal_of_column_(diagonal_of_column), eta_of_column_(eta_of_column) {}

  template <class Derived>
  void addDiagonal(Index position, const Eigen::MatrixBase<Derived>& block) {
    if constexpr (BlockSizes<S...>::kUniform) {
      diagonal_of_column_[position] += block;
    } else {
      diagonal_of_column_[position].topLeftCorner(block.rows(), block.cols()) += block;
    }
  }
  template <class Derived>
  void addEta(Index position, const Eigen::MatrixBase<Derived>& v) {
    if constexpr (BlockSizes<S...>::kUniform) {
      eta_of_column_[position] += v;
    } else {
      eta_of_column_[position].head(v.rows()) += v;
    }
  }

 private:
  Block* diagonal_of_column_;
  Vector* eta_of_column_;
};

template <int... S>
class InformationSource : public NeighbourGraph {
 public:
  // For a factorization that assembles every column, ascending, into columns zeroed beforehand:
  // adds column `variable` of Lambda (diagonal, and rows whose position is greater than
  // position[variable]) and the variable's eta, less what `later` received for it earlier. A
  // source made of factors linearizes each one once, when its first variable in position order is
  // assembled, and passes its share of the later variable's diagonal block and eta to `later`
  // right away (linearizing dominates assembly: three sines and cosines per factor).
  virtual void assembleColumn(Index variable, const Index* position, ColumnAccumulator<S...>& acc,
                              LaterDiagonals<S...>& later) const = 0;
  // Adds only what changed in this update: for every factor of `variable` that was added in this
  // update or touches a relinearized variable, its contribution at the current linearization minus
  // (for old factors) its contribution at the old one. Zero for a column no factor of which
  // changed.
  virtual void assembleColumnChange(Index variable, const Index* position,
                                    ColumnAccumulator<S...>& acc) const = 0;

 protected:
  ~InformationSource() = default;
};

}  // namespace lslam
