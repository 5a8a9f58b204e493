#pragma once
// The checks a model's update passes before anything changes: counts and capacities per kind, each
// input through its kind (ModelVariableInput::check, ModelFactorInput::check), ids (duplicates,
// unknown ids, per id space), and every added variable constrained. A rejected update leaves the id
// maps as they were; an accepted one has the ids it adds in them.
//
// Constrained. An added variable must be held by this update's factors: by a prior, or by a
// factor whose other variables are held and whose rows fix it alone. A factor fixes a variable
// alone when its error dimension is at least the variable's size: a between factor fixes either
// pose, a landmark observation fixes its landmark (2 rows for a Point2, 3 for a Point3) but not the
// pose it is seen from (2 rows for 3 unknowns; 3 for 6). So a landmark enters with its first
// observation (or a prior), and a pose needs a between factor to a held pose or a prior: one seen
// only through landmarks is UnconstrainedVariable, even if several of them would fix it. Without
// this, a singular Lambda would reach the factorization, where rounding could hide it.
#include <cstdint>

#include "lslam/graph/factor_graph.h"
#include "lslam/linear/index.h"
#include "lslam/models/model_traits.h"
#include "lslam/solver/id_map.h"
#include "lslam/solver/model_inputs.h"
#include "lslam/status.h"

namespace lslam {

template <class Model>
class ModelUpdateValidator {
 public:
  static constexpr int kVariableKinds = Model::Variables::kSize;

  // held_scratch: max variables + 1 flags, this validator's alone; ids: one map per variable kind.
  ModelUpdateValidator(std::uint8_t* held_scratch, const FactorGraph<Model>& graph,
                       IdMap* const* ids)
      : held_(held_scratch), graph_(graph) {
    for (int k = 0; k < kVariableKinds; ++k) ids_[k] = ids[k];
  }

  // anchored: the index in `variables` of the input the solver holds itself (it adds a prior of
  // `anchor_factor_values` doubles on it; the first pose input), kNoIndex for none; drop_anchor:
  // this update takes that prior out, so the committed graph must be held by this update's priors.
  // On Ok the ids of `variables` are in the maps, with the indices they get in the graph (appended
  // in input order). Counts the unary factors on poses in *pose_priors.
  [[nodiscard]] Status validate(const ModelVariableInput<Model>* variables, Index num_variables,
                                const ModelFactorInput<Model>* factors, Index num_factors,
                                Index anchored, Index anchor_factor_values, bool drop_anchor,
                                Index* pose_priors);
  // Takes the ids of the first `count` variables out of the maps again (newest first).
  void forgetIds(const ModelVariableInput<Model>* variables, Index count);

  // The graph index of variable `id` of kind `kind` (kNoIndex if unknown).
  Index find(int kind, VariableId id) const { return ids_[kind]->find(id); }

 private:
  Status checkCapacity(const ModelVariableInput<Model>* variables, Index num_variables,
                       const ModelFactorInput<Model>* factors, Index num_factors, bool anchor,
                       Index anchor_factor_values) const;
  Status checkFactors(const ModelFactorInput<Model>* factors, Index num_factors,
                      Index* pose_priors) const;
  Status checkHeld(Index num_variables, const ModelFactorInput<Model>* factors, Index num_factors,
                   Index anchored, bool drop_anchor) const;

  std::uint8_t* held_;
  const FactorGraph<Model>& graph_;
  IdMap* ids_[kVariableKinds] = {};
};

}  // namespace lslam
