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

template <int D>
class InformationSource {
 public:
  // Calls visitor.visit(u) for every variable u sharing a factor with `variable`.
  virtual void visitNeighbours(Index variable, NeighbourVisitor& visitor) const = 0;
  // Adds column `variable` of Lambda (diagonal, and rows whose position is greater than
  // position[variable]) and the variable's eta to `acc`.
  virtual void assembleColumn(Index variable, const Index* position,
                              ColumnAccumulator<D>& acc) const = 0;
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
