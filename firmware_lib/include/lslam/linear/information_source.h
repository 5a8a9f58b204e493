#pragma once
// The factorization never stores Lambda = J^T Omega J. It asks the factor graph for one column of
// it, linearized at the current points, when (and only when) that column of L is recomputed. So
// there is no Lambda to keep in sync, relinearizing a variable changes no stored matrix, and a
// rejected update has no Lambda to roll back.
#include "lslam/eigen.h"
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
template <int D>
class ColumnAccumulator {
 public:
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;

  ColumnAccumulator(Block* blocks, const Index* slot_of_row, Vector* eta)
      : blocks_(blocks), slot_of_row_(slot_of_row), eta_(eta) {}

  void addDiagonal(const Block& block) { blocks_[0] += block; }
  // Lambda(row, column) for a row position after the column (its slot exists by construction).
  void addBelow(Index row, const Block& block) { blocks_[slot_of_row_[row]] += block; }
  void addEta(const Vector& v) { *eta_ += v; }

 private:
  Block* blocks_;
  const Index* slot_of_row_;
  Vector* eta_;
};

// Receives, during a full factorization, the diagonal blocks and eta of columns after the one
// being assembled (see InformationSource::assembleColumn).
template <int D>
class LaterDiagonals {
 public:
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;

  // Column p's diagonal block accumulates in diagonal_of_column[p], its eta in eta_of_column[p].
  LaterDiagonals(Block* diagonal_of_column, Vector* eta_of_column)
      : diagonal_of_column_(diagonal_of_column), eta_of_column_(eta_of_column) {}

  void addDiagonal(Index position, const Block& block) { diagonal_of_column_[position] += block; }
  void addEta(Index position, const Vector& v) { eta_of_column_[position] += v; }

 private:
  Block* diagonal_of_column_;
  Vector* eta_of_column_;
};

template <int D>
class InformationSource : public NeighbourGraph {
 public:
  // For a factorization that assembles every column, ascending, into columns zeroed beforehand:
  // adds column `variable` of Lambda (diagonal, and rows whose position is greater than
  // position[variable]) and the variable's eta, less what `later` received for it earlier. A
  // source made of factors linearizes each one once, when its first variable in position order is
  // assembled, and passes its share of the later variable's diagonal block and eta to `later`
  // right away (linearizing dominates assembly: three sines and cosines per factor).
  virtual void assembleColumn(Index variable, const Index* position, ColumnAccumulator<D>& acc,
                              LaterDiagonals<D>& later) const = 0;
  // Adds only what changed in this update: for every factor of `variable` that was added in this
  // update or touches a relinearized variable, its contribution at the current linearization minus
  // (for old factors) its contribution at the old one. Zero for a column no factor of which
  // changed.
  virtual void assembleColumnChange(Index variable, const Index* position,
                                    ColumnAccumulator<D>& acc) const = 0;

 protected:
  ~InformationSource() = default;
};

}  // namespace lslam
