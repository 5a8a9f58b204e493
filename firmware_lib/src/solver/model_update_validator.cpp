#include "lslam/solver/model_update_validator.h"

#include <type_traits>

#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

namespace lslam {

template <class Model>
Status ModelUpdateValidator<Model>::validate(const ModelVariableInput<Model>* variables,
                                             Index num_variables,
                                             const ModelFactorInput<Model>* factors,
                                             Index num_factors, Index anchored,
                                             Index anchor_factor_values, bool drop_anchor,
                                             Index* pose_priors) {
  *pose_priors = 0;
  if (num_variables < 0 || num_factors < 0 || (num_variables > 0 && variables == nullptr) ||
      (num_factors > 0 && factors == nullptr)) {
    return Status::InvalidArgument;
  }
  if (anchored != kNoIndex && (anchored < 0 || anchored >= num_variables)) {
    return Status::InvalidArgument;
  }
  const bool anchor = anchored != kNoIndex;
  for (Index i = 0; i < num_variables; ++i) {
    const Status s = variables[i].check();
    if (s != Status::Ok) return s;
  }
  Status status =
      checkCapacity(variables, num_variables, factors, num_factors, anchor, anchor_factor_values);
  if (status != Status::Ok) return status;
  // The added ids enter the maps now, so that every lookup below is uniform; forgetIds() undoes it.
  Index inserted = 0;
  for (; inserted < num_variables; ++inserted) {
    const ModelVariableInput<Model>& in = variables[inserted];
    if (ids_[in.kind]->find(in.id) != kNoIndex) {
      status = Status::DuplicateVariable;
      break;
    }
    ids_[in.kind]->insert(in.id, graph_.variables() + inserted);
  }
  if (status == Status::Ok) status = checkFactors(factors, num_factors, pose_priors);
  if (status == Status::Ok)
    status = checkHeld(num_variables, factors, num_factors, anchored, drop_anchor);
  if (status != Status::Ok) forgetIds(variables, inserted);
  return status;
}

template <class Model>
Status ModelUpdateValidator<Model>::checkCapacity(const ModelVariableInput<Model>* variables,
                                                  Index num_variables,
                                                  const ModelFactorInput<Model>* factors,
                                                  Index num_factors, bool anchor,
                                                  Index anchor_factor_values) const {
  Index of_kind[kVariableKinds] = {};
  for (Index i = 0; i < num_variables; ++i) ++of_kind[variables[i].kind];
  for (int k = 0; k < kVariableKinds; ++k) {
    if (of_kind[k] > graph_.freeVariablesOfKind(k)) return Status::CapacityExhausted;
  }
  Index values = anchor ? anchor_factor_values : 0;
  for (Index f = 0; f < num_factors; ++f) {
    // A kind outside the model takes nothing here; checkFactors reports it.
    visitKind<typename Model::Factors>(factors[f].kind, [&](auto* tag) {
      values += kFactorValues<std::remove_pointer_t<decltype(tag)>>;
    });
  }
  if (num_factors + (anchor ? 1 : 0) > graph_.freeFactors() || values > graph_.freeFactorValues()) {
    return Status::CapacityExhausted;
  }
  return Status::Ok;
}

// Each factor's input check, and its ids known in the id spaces of its variables' kinds.
template <class Model>
Status ModelUpdateValidator<Model>::checkFactors(const ModelFactorInput<Model>* factors,
                                                 Index num_factors, Index* pose_priors) const {
  Index priors = 0;
  for (Index f = 0; f < num_factors; ++f) {
    const ModelFactorInput<Model>& in = factors[f];
    const Status s = in.check();
    if (s != Status::Ok) return s;
    Status known = Status::Ok;
    visitKind<typename Model::Factors>(in.kind, [&](auto* tag) {
      using Vars = typename std::remove_pointer_t<decltype(tag)>::Variables;
      constexpr int first = kVariableKind<Model, TypeAtT<0, Vars>>;
      if (ids_[first]->find(in.ids[0]) == kNoIndex) known = Status::UnknownVariable;
      if constexpr (Vars::kSize == 2) {
        constexpr int second = kVariableKind<Model, TypeAtT<1, Vars>>;
        if (ids_[second]->find(in.ids[1]) == kNoIndex) known = Status::UnknownVariable;
      } else {
        priors += first == 0 ? 1 : 0;  // the model's first variable kind is the pose
      }
    });
    if (known != Status::Ok) return known;
  }
  *pose_priors = priors;
  return Status::Ok;
}

// A flood over this update's factors from what is held (see the header), on a node per added
// variable and one for the committed graph as a whole (held unless drop_anchor).
template <class Model>
Status ModelUpdateValidator<Model>::checkHeld(Index num_variables,
                                              const ModelFactorInput<Model>* factors,
                                              Index num_factors, Index anchored,
                                              bool drop_anchor) const {
  const Index first_added = graph_.variables();
  const Index committed = num_variables;
  for (Index i = 0; i < num_variables; ++i) held_[i] = 0;
  if (first_added > 0) held_[committed] = drop_anchor ? 0 : 1;
  Index held = 0;
  const Index required = num_variables + (drop_anchor ? 1 : 0);
  if (anchored != kNoIndex) {
    held_[anchored] = 1;
    held = 1;
  }
  const auto hold = [&](Index node) {
    if (held_[node] == 0) {
      held_[node] = 1;
      ++held;
      return true;
    }
    return false;
  };
  bool progress = true;
  while (progress && held < required) {
    progress = false;
    for (Index f = 0; f < num_factors; ++f) {
      const ModelFactorInput<Model>& in = factors[f];
      visitKind<typename Model::Factors>(in.kind, [&](auto* tag) {
        using F = std::remove_pointer_t<decltype(tag)>;
        using Vars = typename F::Variables;
        using A = TypeAtT<0, Vars>;
        const auto node = [&](int kind, VariableId id) {
          const Index v = ids_[kind]->find(id) - first_added;
          return v < 0 ? committed : v;
        };
        const Index a = node(kVariableKind<Model, A>, in.ids[0]);
        if constexpr (Vars::kSize == 1) {
          progress = hold(a) || progress;
        } else {
          using B = TypeAtT<1, Vars>;
          const Index b = node(kVariableKind<Model, B>, in.ids[1]);
          if (held_[a] != 0 && F::kErrorDim >= B::kDof) progress = hold(b) || progress;
          if (held_[b] != 0 && F::kErrorDim >= A::kDof) progress = hold(a) || progress;
        }
      });
    }
  }
  return held == required ? Status::Ok : Status::UnconstrainedVariable;
}

template <class Model>
void ModelUpdateValidator<Model>::forgetIds(const ModelVariableInput<Model>* variables,
                                            Index count) {
  for (Index i = count - 1; i >= 0; --i) ids_[variables[i].kind]->eraseNewest(variables[i].id);
}

template class ModelUpdateValidator<Slam2D>;
template class ModelUpdateValidator<Slam3D>;
template class ModelUpdateValidator<PoseSlam2D>;
template class ModelUpdateValidator<PoseSlam3D>;

}  // namespace lslam
