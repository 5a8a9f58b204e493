#include "lslam/solver/smoother.h"

#include <new>  // allowed: placement new only, into this object's own storage (no heap)
#include <type_traits>

#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"
#include "update_steps.h"

namespace lslam {
namespace {

template <class Model>
OrderingArrays orderingArrays(const SmootherArrays<Model>& a) {
  OrderingArrays o;
  for (int b = 0; b < 2; ++b) {
    o.position_of[b] = a.position_of[b];
    o.variable_at[b] = a.variable_at[b];
  }
  o.parent_scratch = a.ordering_parent;
  o.count_scratch = a.ordering_count;
  return o;
}

template <class Model>
RelinearizationArrays relinearizationArrays(const SmootherArrays<Model>& a) {
  RelinearizationArrays r;
  r.candidates = a.relinearize_list;
  r.is_candidate = a.relinearize_flag;
  r.staged = a.marked;
  return r;
}

template <class Model>
FactorizationArrays factorizationArrays(const SmootherArrays<Model>& a) {
  FactorizationArrays f;
  f.last_list = a.last_list;
  f.in_last = a.in_last;
  return f;
}

// The factor reads each variable's kind from the graph.
template <class Arrays>
Arrays withKinds(Arrays factor, const std::uint8_t* kinds) {
  factor.variable_kind = kinds;
  return factor;
}

// The pose priors among the inputs (kinds outside the model count none: validation rejects them).
template <class Model>
Index posePriors(const ModelFactorInput<Model>* factors, Index num_factors) {
  Index priors = 0;
  for (Index f = 0; factors != nullptr && f < num_factors; ++f) {
    visitKind<typename Model::Factors>(factors[f].kind, [&](auto* tag) {
      using Vars = typename std::remove_pointer_t<decltype(tag)>::Variables;
      if constexpr (Vars::kSize == 1) priors += kVariableKind<Model, TypeAtT<0, Vars>> == 0 ? 1 : 0;
    });
  }
  return priors;
}

}  // namespace

namespace detail {
// A between factor of two poses measured as a pose (addFolded's kinds).
template <class F, class Pose, bool Binary = F::Variables::kSize == 2>
struct IsPoseBetween : std::false_type {};
template <class F, class Pose>
struct IsPoseBetween<F, Pose, true>
    : std::bool_constant<std::is_same_v<TypeAtT<0, typename F::Variables>, Pose> &&
                         std::is_same_v<TypeAtT<1, typename F::Variables>, Pose> &&
                         std::is_same_v<typename F::Measurement, Pose> &&
                         F::kErrorDim == Pose::kDof> {};
template <class F, class Pose>
inline constexpr bool kPoseBetween = IsPoseBetween<F, Pose>::value;
// The point observation of a model with landmarks (its error is linear in the measurement).
template <class Model, class F, class = void>
struct IsPointObservation : std::false_type {};
template <class Model, class F>
struct IsPointObservation<Model, F, std::void_t<typename Model::PointObservation>>
    : std::is_same<F, typename Model::PointObservation> {};
// The kinds addFolded merges.
template <class Model, class F, class Pose>
inline constexpr bool kFoldable = kPoseBetween<F, Pose> || IsPointObservation<Model, F>::value;
}  // namespace detail

namespace {

// The factorization work of an iteration, added to the call's.
void addWork(UpdateResult& into, const UpdateResult& step) {
  into.variables_relinearized += step.variables_relinearized;
  into.columns_refactored += step.columns_refactored;
  into.block_products += step.block_products;
}

}  // namespace

template <class Model>
Smoother<Model>::Smoother(const SmootherArrays<Model>& arrays, const FactorGraphArrays& graph,
                          const FactorArrays& factor, const ColamdArrays& ordering,
                          const IdMapArrays* ids, const SolverOptions& options,
                          const SpreadArrays<Model>* spread)
    : options_(options),
      graph_(graph),
      cholesky_(withKinds(factor, graph_.variableKinds())),
      ids_{IdMap(ids[0]), IdMap(ids[1])},
      id_maps_{&ids_[0], &ids_[1]},
      id_of_(arrays.id_of),
      delta_(arrays.delta),
      visited_(arrays.visited),
      validator_(arrays.held, graph_, id_maps_),
      ordering_(orderingArrays(arrays), ordering, graph_, cholesky_, options_),
      relinearization_(relinearizationArrays(arrays), graph_, cholesky_, options_),
      driver_(factorizationArrays(arrays), graph_, cholesky_, options_) {
  if (spread != nullptr) {
    // Placement new, allowed here: it builds the two objects in this object's own storage
    // (spare_storage_, spread_storage_), no heap, once, at construction; both are trivially
    // destructible. They exist only when the caller gives their memory.
    spare_ = new (spare_storage_)  // placement new into own storage, no heap: allowed (above)
        Factor(withKinds(spread->factor, graph_.variableKinds()));
    spread_ = new (spread_storage_)  // placement new into own storage, no heap: allowed (above)
        Spread(spread->reordering, graph_, *spare_, options_);
  }
}

template <class Model>
Status Smoother<Model>::update(const Variable* variables, Index num_variables,
                               const Measurement* factors, Index num_factors,
                               UpdateResult* result) {
  UpdateResult local;
  UpdateResult& r = result != nullptr ? *result : local;
  r = UpdateResult{};
  // The gauge (see smoother.h): the first update anchors its first pose input unless it brings a
  // pose prior of the caller's; the first caller pose prior after that takes the anchor out.
  Index anchored = kNoIndex;
  const Index priors = num_factors > 0 ? posePriors(factors, num_factors) : 0;
  if (graph_.variables() == 0 && priors == 0 && variables != nullptr) {
    for (Index i = 0; i < num_variables && anchored == kNoIndex; ++i) {
      if (variables[i].kind == 0) anchored = i;
    }
  }
  const bool drop_anchor = gauge_.dropsAnchor(priors);
  Index validated_priors = 0;
  Status s =
      validator_.validate(variables, num_variables, factors, num_factors, anchored,
                          kFactorValues<typename Model::PosePrior>, drop_anchor, &validated_priors);
  if (s != Status::Ok) {
    r.status = s;
    return s;
  }
  LSLAM_DEBUG_ASSERT(validated_priors == priors);
  graph_.beginUpdate();
  driver_.beginStaging();
  addInputs(variables, num_variables, factors, num_factors);
  if (anchored != kNoIndex) {
    // The first pose stays where it was given (chi2 is gauge-invariant, so the strength of this
    // prior does not change the optimum).
    using Prior = typename Model::PosePrior;
    using Info = Eigen::Matrix<double, Prior::kErrorDim, Prior::kErrorDim>;
    static_cast<void>(graph_.template addFactor<Prior>(
        anchored, kNoIndex, variables[anchored].template get<Pose>(),
        Info::Identity() * options_.anchor_information));
  }
  if (drop_anchor) graph_.disablePrior(gauge_.anchorFactor());
  r.laid_out = cholesky_.layoutPending();
  const UpdatePlan plan = planUpdate(num_variables, drop_anchor);
  s = refactor(num_variables, plan, true, r);
  if (s != Status::Ok) {
    validator_.forgetIds(variables, num_variables);
    r.status = s;
    return s;
  }
  // The anchor is the last factor of its update (added after the caller's).
  gauge_.commit(anchored != kNoIndex, drop_anchor, graph_.factors() - 1);
  relinearization_.noteUpdate(plan.relinearize_now, plan.relinearization_deferred, delta_);
  for (Index i = 0; i < num_variables; ++i) {
    id_of_[graph_.variables() - num_variables + i] = variables[i].id;
  }
  r.variables_added = num_variables;
  r.factors_added = graph_.factors() - driver_.firstNewFactor();
  LSLAM_DEBUG_ASSERT(!(plan.prepare_ordering && r.reordered));
  if (plan.prepare_ordering) r.ordering_prepared = ordering_.prepareOrdering();
  stepSpread(plan, r);
  if (options_.solve_after_update) solve(false, &r);
  return Status::Ok;
}

template <class Model>
void Smoother<Model>::stepSpread(const UpdatePlan& plan, UpdateResult& r) {
  if (spread_ == nullptr) return;
  if (plan.abandon_spread || r.variables_relinearized > 0 || r.refactored_fully) {
    r.spread_abandoned = spreadActive();
    // Given up for a relinearization, not for a reordering done here: the next runs in one update.
    spread_failed_ = spread_failed_ || (r.spread_abandoned && !r.reordered);
    abandonSpread();
    return;
  }
  if (plan.start_spread) {
    // The prepared ordering (or the current one), and the candidates a reordering would
    // relinearize.
    const bool prepared = !plan.spread_in_current_order;
    if (prepared) ordering_.takePreparedOrdering();
    graph_.beginUpdate();
    const Index count = relinearization_.stageCandidates(CandidateRange::PastThreshold, delta_, 0);
    graph_.rollback();
    const Status s = spread_->start(prepared ? ordering_.otherVariableAt() : variableAt(),
                                    prepared ? ordering_.otherPositionOf() : positionOf(),
                                    relinearization_.staged(), count, delta_);
    if (prepared) ordering_.forgetPrepared();
    spread_in_current_order_ = !prepared;
    r.spread_started = s == Status::Ok;
    spread_failed_ = s != Status::Ok;
    // Each update takes an equal share of the refactorization (the last one's, scaled by the
    // growth since), over at most kSpreadUpdates updates.
    const double predicted = predictedFullProducts(driver_.lastFull(), cholesky_.liveBlocks());
    spread_share_ = std::max(options_.spread_reorder_products,
                             static_cast<std::int64_t>(predicted / kSpreadUpdates));
    return;
  }
  if (!spread_->active()) return;
  if (!spread_->advance(spread_share_)) {
    r.spread_abandoned = true;
    spread_failed_ = true;
    return;
  }
  r.spread_products = spread_->lastProducts();
  if (spread_->ready()) swapInSpread(r);
}

// The spread reordering's factor replaces the live one: its points and its order become the
// solver's, as after a reordering done in one update.
template <class Model>
void Smoother<Model>::swapInSpread(UpdateResult& r) {
  graph_.beginUpdate();
  spread_->stageRelinearization();
  graph_.commit();
  cholesky_.swap(*spare_);
  ordering_.adoptOrder(spread_->variableAt(), spread_->positionOf());
  const FactorizationStats& built = spread_->buildStats();
  // (A relinearization spread in the current order is no reordering: the growth and the work
  // budget since the last one go on.)
  ordering_.noteFactorization(!spread_in_current_order_, true, built, 0);
  driver_.noteFullRefactorization(built.block_products, spread_->buildBlocks());
  for (Index i = 0; i < spread_->relinearizedCount(); ++i) {
    delta_[spread_->relinearized()[i]].setZero();
  }
  cholesky_.loadSolution(delta_, variableAt());
  relinearization_.noteUpdate(true, false, delta_);
  r.reordered = !spread_in_current_order_;
  r.refactored_fully = true;
  r.spread_swapped = true;
  r.variables_relinearized += spread_->relinearizedCount();
  r.factor_blocks = cholesky_.liveBlocks();
  spread_->finish();
}

template <class Model>
Status Smoother<Model>::addFolded(const Measurement& factor, Index into, UpdateResult* result) {
  bool matches = false;
  if (into >= 0 && into < graph_.factors() && into != gauge_.anchorFactor() &&
      graph_.factorKind(into) == factor.kind) {
    visitKind<typename Model::Factors>(factor.kind, [&](auto* tag) {
      using F = std::remove_pointer_t<decltype(tag)>;
      if constexpr (detail::kFoldable<Model, F, Pose>) {
        using Vars = typename F::Variables;
        const IdMap& second = ids_[kVariableKind<Model, TypeAtT<1, Vars>>];
        matches = ids_[0].find(factor.ids[0]) == graph_.firstVariable(into) &&
                  second.find(factor.ids[1]) == graph_.secondVariable(into);
      }
    });
  }
  if (!matches) {
    if (result != nullptr) *result = UpdateResult{Status::InvalidArgument};
    return Status::InvalidArgument;
  }
  const Status s = update(nullptr, 0, &factor, 1, result);
  if (s != Status::Ok) return s;
  visitKind<typename Model::Factors>(factor.kind, [&](auto* tag) {
    using F = std::remove_pointer_t<decltype(tag)>;
    if constexpr (detail::kFoldable<Model, F, Pose>) {
      const Index newest = graph_.factors() - 1;
      Eigen::Matrix<double, F::kErrorDim, F::kErrorDim> information;
      const typename F::Measurement z = mergedMeasurement(
          graph_.template measurement<F>(into), graph_.template information<F>(into),
          graph_.template measurement<F>(newest), graph_.template information<F>(newest),
          &information);
      graph_.template foldNewestFactor<F>(into, z, information);
    }
  });
  abandonSpread();  // the folded factor changed
  return Status::Ok;
}

// The staged graph change of validated inputs: the variables in input order (the indices the
// validator gave their ids), then each factor on its variables' indices.
template <class Model>
void Smoother<Model>::addInputs(const Variable* variables, Index num_variables,
                                const Measurement* factors, Index num_factors) {
  for (Index i = 0; i < num_variables; ++i) {
    const Variable& in = variables[i];
    visitKind<typename Model::Variables>(in.kind, [&](auto* tag) {
      using V = std::remove_pointer_t<decltype(tag)>;
      static_cast<void>(graph_.template addVariable<V>(in.template get<V>()));
    });
  }
  for (Index f = 0; f < num_factors; ++f) {
    const Measurement& in = factors[f];
    visitKind<typename Model::Factors>(in.kind, [&](auto* tag) {
      using F = std::remove_pointer_t<decltype(tag)>;
      using Vars = typename F::Variables;
      const Index first = ids_[kVariableKind<Model, TypeAtT<0, Vars>>].find(in.ids[0]);
      Index second = kNoIndex;
      if constexpr (Vars::kSize == 2) {
        second = ids_[kVariableKind<Model, TypeAtT<1, Vars>>].find(in.ids[1]);
      }
      static_cast<void>(graph_.template addFactor<F>(first, second, in.template measurementAs<F>(),
                                                     in.template informationAs<F>()));
    });
  }
}

// See detail::planUpdate (update_steps.h).
template <class Model>
UpdatePlan Smoother<Model>::planUpdate(Index new_variables, bool drop_anchor, bool force_reorder) {
  detail::SpreadState spread;
  spread.available = spread_ != nullptr && !spread_failed_;
  spread.active = spreadActive();
  spread.above_products = options_.spread_reorder_products;
  return detail::planUpdate(graph_, ordering_, relinearization_, driver_, delta_, new_variables,
                            drop_anchor, force_reorder, spread);
}

// See detail::refactorAndRestart (update_steps.h).
template <class Model>
Status Smoother<Model>::refactor(Index new_variables, const UpdatePlan& plan, bool allow_reorder,
                                 UpdateResult& r) {
  const Status s = detail::refactorAndRestart(cholesky_, ordering_, relinearization_, driver_,
                                              delta_, new_variables, plan, allow_reorder, r);
  if (s == Status::Ok && r.reordered) spread_failed_ = false;  // one update reordered after it
  return s;
}

template <class Model>
void Smoother<Model>::solve(bool full, UpdateResult* result) {
  backSubstitute(full, result);
  const Index iterations = relinearization_.iterationsWithinSolve();
  for (Index i = 0; i < iterations && relinearization_.urgent(); ++i) {
    UpdateResult step;
    // A failed pass, or one whose relinearization must wait for a reordering
    // (relinearize_defer_products), changed nothing: the solution stands, the candidates wait.
    if (relinearizeCandidates(step) != Status::Ok) break;
    if (step.relinearization_deferred) {
      if (result != nullptr) result->relinearization_deferred = true;
      break;
    }
    backSubstitute(full, result);
    if (result == nullptr) continue;
    result->iterations = i + 1;
    addWork(*result, step);
    result->reordered = result->reordered || step.reordered;
    result->refactored_fully = result->refactored_fully || step.refactored_fully;
    result->factor_blocks = step.factor_blocks;
  }
}

template <class Model>
void Smoother<Model>::backSubstitute(bool full, UpdateResult* result) {
  const bool exact = full || !options_.partial_backsubstitution;
  const Index visited = cholesky_.backSubstitute(
      delta_, variableAt(), options_.backsubstitution_tolerance, exact, visited_);
  relinearization_.noteCandidates(visited_, visited, variableAt());
  if (result != nullptr) result->variables_solved = visited;
}

template <class Model>
Status Smoother<Model>::relinearizeCandidates(UpdateResult& result) {
  if (spreadActive()) {  // the candidates wait for the spread reordering (see planUpdate)
    result.relinearization_deferred = true;
    return Status::Ok;
  }
  graph_.beginUpdate();
  driver_.beginStaging();
  const UpdatePlan plan = planUpdate(0, false);
  if (plan.relinearization_deferred || plan.start_spread) {
    // (A spread reordering starts with the next update, and relinearizes.)
    // Nothing to factorize: the wait is counted, and charged, by updates alone.
    graph_.rollback();
    result.relinearization_deferred = true;
    return Status::Ok;
  }
  const Status s = refactor(0, plan, true, result);
  if (s != Status::Ok) return s;
  relinearization_.noteUpdate(plan.relinearize_now, plan.relinearization_deferred, delta_);
  if (plan.prepare_ordering) result.ordering_prepared = ordering_.prepareOrdering();
  return Status::Ok;
}

template <class Model>
Status Smoother<Model>::reorder(UpdateResult* result) {
  UpdateResult local;
  UpdateResult& r = result != nullptr ? *result : local;
  r = UpdateResult{};
  graph_.beginUpdate();
  driver_.beginStaging();
  r.laid_out = cholesky_.layoutPending();
  const UpdatePlan plan = planUpdate(0, false, true);
  const Status s = refactor(0, plan, true, r);
  if (s != Status::Ok) {
    r.status = s;
    return s;
  }
  abandonSpread();
  relinearization_.noteUpdate(plan.relinearize_now, plan.relinearization_deferred, delta_);
  if (options_.solve_after_update) solve(false, &r);
  return Status::Ok;
}

template <class Model>
Status Smoother<Model>::optimize(Index max_iterations, double tolerance, UpdateResult* result) {
  UpdateResult local;
  UpdateResult& r = result != nullptr ? *result : local;
  r = UpdateResult{};
  if (max_iterations < 0 || !(tolerance >= 0.0)) {
    r.status = Status::InvalidArgument;
    return Status::InvalidArgument;
  }
  abandonSpread();  // it relinearizes
  solve(true, nullptr);
  for (Index it = 0; it < max_iterations; ++it) {
    graph_.beginUpdate();
    driver_.beginStaging();
    const Index relinearized = relinearization_.stageEveryMovedVariable(delta_, tolerance);
    if (relinearized == 0) {
      graph_.commit();  // nothing staged: commit is a no-op
      break;
    }
    UpdateResult step;
    UpdatePlan plan;
    plan.relinearized = relinearized;
    const Status s = refactor(0, plan, false, step);
    if (s != Status::Ok) {
      r.status = s;
      return s;
    }
    relinearization_.clearCandidates();
    solve(true, nullptr);
    r.iterations = it + 1;
    addWork(r, step);
  }
  r.factor_blocks = cholesky_.liveBlocks();
  return Status::Ok;
}

// The caller's factors only: the anchor is skipped (a dropped one has zero information).
template <class Model>
double Smoother<Model>::chi2() const {
  double total = 0.0;
  for (Index f = 0; f < graph_.factors(); ++f) {
    if (f == gauge_.anchorFactor()) continue;
    visitKind<typename Model::Factors>(graph_.factorKind(f), [&](auto* tag) {
      using F = std::remove_pointer_t<decltype(tag)>;
      using Vars = typename F::Variables;
      const auto z = graph_.template measurement<F>(f);
      const auto a = estimateAt<TypeAtT<0, Vars>>(graph_.firstVariable(f));
      Eigen::Matrix<double, F::kErrorDim, 1> e;
      if constexpr (Vars::kSize == 1) {
        e = F::error(a, z, nullptr);
      } else {
        const auto b = estimateAt<TypeAtT<1, Vars>>(graph_.secondVariable(f));
        e = F::error(a, b, z, nullptr, nullptr);
      }
      total += e.dot(graph_.template information<F>(f) * e);
    });
  }
  return total;
}

template class Smoother<Slam2D>;
template class Smoother<Slam3D>;
template class Smoother<PoseSlam2D>;
template class Smoother<PoseSlam3D>;

}  // namespace lslam
