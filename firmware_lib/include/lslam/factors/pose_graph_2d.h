#pragma once
// The 2D pose graph as the solver holds it: each variable's linearization point, each factor's
// measurement and information, and, per variable, the list of factors that touch it. It is the
// InformationSource of the factorization: a column of Lambda is linearized from these factors on
// demand, so there is no stored Lambda to keep in sync.
//
// Every change belongs to an update that is committed or rolled back as a whole, and a rollback
// restores every stored value bit for bit (factors are appended, relinearizations and a disabled
// prior are staged).
//
// Information matrices are stored symmetric: an input that is symmetric only to rounding
// (checkInformation accepts 1e-9 relative) is stored as its symmetric part (symmetricPart), so
// that every use of it (Omega in J^T Omega J, its Cholesky factor in whitenedRows) is of one
// matrix.
#include <cstdint>

#include "lslam/eigen.h"
#include "lslam/geometry/se2.h"
#include "lslam/linear/index.h"
#include "lslam/linear/information_source.h"

namespace lslam {

enum class FactorKind : std::uint8_t { PriorSE2, BetweenSE2 };

// The variables a factor of this kind connects: 1 (a prior) or 2 (a between); 0 for a value that
// names no kind (one from outside, cast from an integer). The single dispatch on an input's kind,
// so that what validates an input and what adds it cannot disagree.
constexpr int factorArity(FactorKind kind) noexcept {
  switch (kind) {
    case FactorKind::PriorSE2:
      return 1;
    case FactorKind::BetweenSE2:
      return 2;
  }
  return 0;
}

// A between factor's share of Lambda and eta at given points of its two variables (first, second):
// J_first^T Omega J_first, J_second^T Omega J_second, J_second^T Omega J_first = Lambda(second,
// first), and -J^T Omega e for each. Always computed by the same expression, whether kept in the
// cache or not, so that a cached value and a fresh one are the same bits.
struct LinearizedBetween {
  Mat3 first_first;
  Mat3 second_second;
  Mat3 second_first;
  Vec3 eta_first;
  Vec3 eta_second;
};

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
  // The linearization cache (see PoseGraph2D): per variable, the epoch its committed point last
  // changed; per factor, the cached linearization and the epoch it was computed in (0: none).
  // linearized and linearized_epoch may be null: no cache.
  std::uint32_t* point_epoch = nullptr;       // max_variables
  LinearizedBetween* linearized = nullptr;    // max_factors
  std::uint32_t* linearized_epoch = nullptr;  // max_factors
};

class PoseGraph2D final : public InformationSource<3> {
 public:
  // cache_linearizations: keep each factor's linearization for the next full refactorization
  // (needs the arrays' cache; off, or without them, every linearization is computed afresh).
  explicit PoseGraph2D(const PoseGraph2DArrays& arrays, bool cache_linearizations = true);

  Index variables() const { return num_variables_; }
  Index factors() const { return num_factors_; }
  Index maxVariables() const { return a_.max_variables; }
  Index maxFactors() const { return a_.max_factors; }

  void beginUpdate();
  Index addVariable(const SE2& initial);
  Index addPrior(Index variable, const SE2& z, const Mat3& information);
  Index addBetween(Index from, Index to, const SE2& z, const Mat3& information);
  // Takes a committed prior out of the problem: its information becomes zero, so that it adds
  // nothing to Lambda, eta or the error (it stays in its variable's factor list). At most one per
  // update; a rollback restores it. No column change is assembled for it: the update that disables
  // a prior must refactorize every column.
  void disablePrior(Index factor);
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
  // The committed point, or the current one (staged inside an update).
  const SE2& pointOf(Index variable, bool committed) const {
    return committed ? a_.linearization[variable] : linearizationPoint(variable);
  }
  // The factor's other variable (kNoIndex for a prior).
  Index otherVariable(Index factor, Index variable) const {
    return a_.first_variable[factor] == variable ? a_.second_variable[factor]
                                                 : a_.first_variable[factor];
  }
  // Adds (or subtracts) the factor's share of Lambda's column `variable`, and of eta, linearized
  // at the current points (committed == false) or at the committed ones.
  void addContribution(Index factor, Index variable, const Index* position, bool committed,
                       bool subtract, ColumnAccumulator<3>& acc) const;
  void advanceEpoch();
  void forgetStagedLinearizations();
  Index appendFactor(FactorKind kind, Index first, Index second, const SE2& z,
                     const Mat3& information);
  void link(Index variable, Index factor);
  // The between factor's linearization at the committed points (committed) or the current ones:
  // from the cache when it holds it, else computed and kept (at staged points only if keep_staged:
  // a full refactorization, which uses each factor once).
  const LinearizedBetween& linearizedBetween(Index factor, bool committed, bool keep_staged,
                                             LinearizedBetween& scratch) const;
  void computeLinearizedBetween(Index factor, const SE2& first, const SE2& second,
                                LinearizedBetween& out) const;

  PoseGraph2DArrays a_;
  Index num_variables_ = 0;
  Index num_factors_ = 0;
  Index num_entries_ = 0;
  Index committed_variables_ = 0;
  Index committed_factors_ = 0;
  Index committed_entries_ = 0;
  std::uint32_t stamp_ = 1;
  // Advances at every commit that moves a linearization point; a cached linearization is valid
  // while its epoch is not older than either variable's point_epoch.
  std::uint32_t epoch_ = 1;
  Index staged_count_ = 0;
  Index disabled_ = kNoIndex;  // the prior disabled by the update in progress
  Mat3 disabled_information_;  // ...and its information before
  bool in_update_ = false;
  bool cache_ = false;

  friend struct PoseGraph2DTestAccess;  // tests start the epoch near its wrap
};

namespace detail {

// The linearization cache's memory: 268 bytes per factor (a Cortex-M can leave it out).
template <Index MaxFactors, bool Present>
struct LinearizationCacheStorage {
  LinearizedBetween* entries() { return entries_; }
  std::uint32_t* epochs() { return epochs_; }

 private:
  LinearizedBetween entries_[MaxFactors];
  std::uint32_t epochs_[MaxFactors];
};

template <Index MaxFactors>
struct LinearizationCacheStorage<MaxFactors, false> {
  LinearizedBetween* entries() { return nullptr; }
  std::uint32_t* epochs() { return nullptr; }
};

}  // namespace detail

// Memory for a PoseGraph2D; LinearizationCache adds the cache (see PoseGraph2D).
template <Index MaxVariables, Index MaxFactors, bool LinearizationCache = true>
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
    a.point_epoch = point_epoch_;
    a.linearized = cache_.entries();
    a.linearized_epoch = cache_.epochs();
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
  std::uint32_t point_epoch_[MaxVariables];
  detail::LinearizationCacheStorage<MaxFactors, LinearizationCache> cache_;
};

}  // namespace lslam
