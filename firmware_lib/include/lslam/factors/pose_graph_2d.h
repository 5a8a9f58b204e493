#pragma once
// The 2D pose graph as the solver holds it: each variable's linearization point, each factor's
// measurement and information, and, per variable, the list of factors that touch it. It is the
// InformationSource of the factorization: a column of Lambda is linearized from these factors on
// demand, so there is no stored Lambda to keep in sync.
//
// Every change belongs to an update that is committed or rolled back as a whole, and a rollback
// restores every stored value bit for bit (factors are appended, relinearizations are staged).
#include <cstdint>

#include "lslam/eigen.h"
#include "lslam/geometry/se2.h"
#include "lslam/linear/index.h"
#include "lslam/linear/information_source.h"

namespace lslam {

enum class FactorKind : std::uint8_t { PriorSE2, BetweenSE2 };

struct PoseGraph2DArrays {
  Index max_variables = 0;
  Index max_factors = 0;
  SE2* linearization = nullptr;         // max_variables
  SE2* staged_linearization = nullptr;  // max_variables
  std::uint32_t* staged = nullptr;      // max_variables
  Index* staged_list = nullptr;         // max_variables
  Index* first_entry = nullptr;         // max_variables: head of the variable's factor list
  FactorKind* kind = nullptr;           // max_factors
  Index* first_variable = nullptr;      // max_factors
  Index* second_variable = nullptr;     // max_factors (kNoIndex for a prior)
  SE2* measurement = nullptr;           // max_factors
  Mat3* information = nullptr;          // max_factors
  Index* entry_factor = nullptr;        // 2 * max_factors: the factor-list links
  Index* next_entry = nullptr;          // 2 * max_factors
};

class PoseGraph2D final : public InformationSource<3> {
 public:
  explicit PoseGraph2D(const PoseGraph2DArrays& arrays);

  Index variables() const { return num_variables_; }
  Index factors() const { return num_factors_; }
  Index maxVariables() const { return a_.max_variables; }
  Index maxFactors() const { return a_.max_factors; }

  void beginUpdate();
  Index addVariable(const SE2& initial);
  Index addPrior(Index variable, const SE2& z, const Mat3& information);
  Index addBetween(Index from, Index to, const SE2& z, const Mat3& information);
  // Moves the linearization point of `variable` (staged until commit).
  void relinearize(Index variable, const SE2& point);
  // Forgets the linearization points staged by relinearize() in this update (the update's added
  // variables and factors stay).
  void unstageRelinearization();
  void commit();
  void rollback();

  // The point a variable is linearized at (staged value inside an update).
  const SE2& linearizationPoint(Index variable) const;

  // Iteration over the factors touching a variable: for (e = firstEntry(v); e != kNoIndex;
  // e = nextEntry(e)) { f = entryFactor(e); }
  Index firstEntry(Index variable) const { return a_.first_entry[variable]; }
  Index nextEntry(Index entry) const { return a_.next_entry[entry]; }
  Index entryFactor(Index entry) const { return a_.entry_factor[entry]; }
  FactorKind kind(Index factor) const { return a_.kind[factor]; }
  Index firstVariable(Index factor) const { return a_.first_variable[factor]; }
  Index secondVariable(Index factor) const { return a_.second_variable[factor]; }
  const SE2& measurement(Index factor) const { return a_.measurement[factor]; }
  const Mat3& information(Index factor) const { return a_.information[factor]; }

  // Whitened squared error e^T Omega e of one factor at the given poses' linearization points.
  double factorChi2(Index factor) const;
  // The factor linearized at the current points as whitened rows [A b] (Omega = R^T R, A = R J,
  // b = -R e, so that A^T A and A^T b are its share of Lambda and eta): for each of its variables
  // (returned count, at most 2) the column position and the block A_v^T, and b.
  Index whitenedRows(Index factor, const Index* position, Index* positions, Mat3* rows_transposed,
                     Vec3* rhs) const;

  void visitNeighbours(Index variable, NeighbourVisitor& visitor) const override;
  void assembleColumnChange(Index variable, const Index* position,
                            ColumnAccumulator<3>& acc) const override;
  void assembleColumn(Index variable, const Index* position, ColumnAccumulator<3>& acc,
                      LaterDiagonals<3>& later) const override;

 private:
  bool isStaged(Index variable) const { return in_update_ && a_.staged[variable] == stamp_; }
  // The factor's other variable (kNoIndex for a prior).
  Index otherVariable(Index factor, Index variable) const {
    return a_.first_variable[factor] == variable ? a_.second_variable[factor]
                                                 : a_.first_variable[factor];
  }
  // Adds sign * (the factor's share of Lambda's column `variable`, and of eta), linearized at the
  // current points (committed == false) or at the committed ones.
  void addContribution(Index factor, Index variable, const Index* position, bool committed,
                       double sign, ColumnAccumulator<3>& acc) const;
  void link(Index variable, Index factor);

  PoseGraph2DArrays a_;
  Index num_variables_ = 0;
  Index num_factors_ = 0;
  Index num_entries_ = 0;
  Index committed_variables_ = 0;
  Index committed_factors_ = 0;
  Index committed_entries_ = 0;
  std::uint32_t stamp_ = 1;
  Index staged_count_ = 0;
  bool in_update_ = false;
};

// Memory for a PoseGraph2D.
template <Index MaxVariables, Index MaxFactors>
class StaticPoseGraph2DStorage {
 public:
  PoseGraph2DArrays arrays() {
    PoseGraph2DArrays a;
    a.max_variables = MaxVariables;
    a.max_factors = MaxFactors;
    a.linearization = linearization_;
    a.staged_linearization = staged_linearization_;
    a.staged = staged_;
    a.staged_list = staged_list_;
    a.first_entry = first_entry_;
    a.kind = kind_;
    a.first_variable = first_variable_;
    a.second_variable = second_variable_;
    a.measurement = measurement_;
    a.information = information_;
    a.entry_factor = entry_factor_;
    a.next_entry = next_entry_;
    return a;
  }

 private:
  SE2 linearization_[MaxVariables];
  SE2 staged_linearization_[MaxVariables];
  std::uint32_t staged_[MaxVariables];
  Index staged_list_[MaxVariables];
  Index first_entry_[MaxVariables];
  FactorKind kind_[MaxFactors];
  Index first_variable_[MaxFactors];
  Index second_variable_[MaxFactors];
  SE2 measurement_[MaxFactors];
  Mat3 information_[MaxFactors];
  Index entry_factor_[2 * MaxFactors];
  Index next_entry_[2 * MaxFactors];
};

}  // namespace lslam
