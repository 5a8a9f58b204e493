#include "lslam/solver/factorization_driver.h"

#include <algorithm>

#include "lslam/assert.h"
#include "lslam/graph/factor_graph.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

namespace lslam {
namespace {

template <class Factor>
class ColumnMarker final : public NeighbourVisitor {
 public:
  ColumnMarker(Factor& factor, const Index* position_of)
      : factor_(factor), position_of_(position_of) {}
  void visit(Index variable) override { factor_.markChanged(position_of_[variable]); }

 private:
  Factor& factor_;
  const Index* position_of_;
};

}  // namespace

template <class Graph, class Factor>
FactorizationDriver<Graph, Factor>::FactorizationDriver(const FactorizationArrays& arrays,
                                                        Graph& graph, Factor& factor,
                                                        const SolverOptions& options)
    : a_(arrays), graph_(graph), factor_(factor), options_(options) {
  for (Index v = 0; v < graph_.maxVariables(); ++v) a_.in_last[v] = 0;
}

template <class Graph, class Factor>
std::int64_t FactorizationDriver<Graph, Factor>::inPlaceProducts(
    Index new_columns, const Index* position_of, const StagedVariables& relinearized) {
  factor_.beginUpdate(new_columns, false);
  markAffectedColumns(position_of, relinearized);
  const std::int64_t in_place = factor_.inPlaceProducts();
  factor_.rollback();
  return in_place;
}

template <class Graph, class Factor>
Status FactorizationDriver<Graph, Factor>::refactor(Ordering& ordering, const UpdatePlan& plan,
                                                    const StagedVariables& relinearized,
                                                    Index new_poses, bool allow_reorder,
                                                    bool* positions_moved, UpdateResult& r) {
  LSLAM_ASSERT(allow_reorder || !plan.reorder_now);
  LSLAM_ASSERT(relinearized.count == plan.relinearized);
  bool full = plan.reorder_now || plan.refactor_fully;
  bool reorder = plan.reorder_now || (full && !ordering.orderingFresh());
  int buffer = ordering.active();
  bool fresh = false;  // the ordering computed here, with this update's factors in it
  bool prepared_overwritten = false;
  if (reorder) {
    buffer = ordering.other();
    if (ordering.prepared() && !plan.fresh_ordering) {
      ordering.takePreparedOrdering();
    } else {
      reorder = fresh = ordering.computeFreshOrdering(&prepared_overwritten);
    }
    if (!reorder && plan.reorder_required) {  // no workspace for the ordering asked for
      graph_.rollback();
      if (prepared_overwritten) ordering.prepareOrdering();
      r.status = Status::WorkspaceExhausted;
      return Status::WorkspaceExhausted;
    }
    if (!reorder) buffer = ordering.active();  // no workspace for an ordering: keep the current one
    full = reorder || plan.drop_anchor;
  }
  // (In the active order the added variables are last already: placeAddedVariablesLast.)
  bool top_reordered = false;
  Status s =
      factorizeWithRetry(ordering, full, allow_reorder, new_poses, ordering.variableAt(buffer),
                         ordering.positionOf(buffer), relinearized, &top_reordered, r);
  if (s == Status::CapacityExhausted && allow_reorder && !fresh) {
    // The update's fill does not fit in an order chosen without its factors (a burst of loop
    // closures, say from a file that lists them after every pose): a fresh order over every
    // factor, this update's included, usually fits.
    const int other = ordering.other();
    fresh = ordering.computeFreshOrdering(&prepared_overwritten);
    if (fresh) {
      buffer = other;
      reorder = full = true;
      r.reordered_for_room = true;
      s = factorizeWithRetry(ordering, true, allow_reorder, new_poses, ordering.variableAt(other),
                             ordering.positionOf(other), relinearized, &top_reordered, r);
    }
  }
  if (s != Status::Ok) {
    graph_.rollback();
    // A fresh ordering overwrote the prepared one; the same committed graph prepares it again.
    if (prepared_overwritten) ordering.prepareOrdering();
    r.status = s;
    return s;
  }
  if (top_reordered) buffer = ordering.other();  // the reordered update wrote the other buffer
  // Applied, or overwritten (by a reordered update of the top, or by an ordering that could not
  // be computed).
  if (reorder || top_reordered || prepared_overwritten) ordering.forgetPrepared();
  graph_.commit();
  ordering.activate(buffer);
  *positions_moved = reorder || top_reordered;
  const FactorizationStats& stats = factor_.lastStats();
  ordering.noteFactorization(reorder, full, stats, plan.deferred_products);
  if (full) {
    last_full_.products = stats.block_products;
    last_full_.blocks = factor_.liveBlocks();
  }
  if (!full) largest_staging_ = std::max(largest_staging_, stats.blocks_written);
  r.reordered = reorder;
  r.refactored_fully = full;
  r.top_reordered = top_reordered;
  r.relinearization_deferred = plan.relinearization_deferred;
  r.relinearization_charge = plan.deferred_products;
  r.variables_relinearized = relinearized.count;
  r.columns_refactored = stats.columns_recomputed;
  r.block_products = stats.block_products;
  r.factor_blocks = factor_.liveBlocks();
  return Status::Ok;
}

template <class Graph, class Factor>
Status FactorizationDriver<Graph, Factor>::addCommittedFactors(Index first, Index end,
                                                               Index new_columns,
                                                               const Index* variable_at,
                                                               const Index* position_of) {
  first_new_factor_ = first;
  end_new_factor_ = end;
  factor_.beginUpdate(new_columns, false, variable_at);
  const Status s = rowUpdateAndCommit(position_of, new_columns);
  end_new_factor_ = kNoIndex;
  return s;
}

// The update's factors as row updates of the factor (its update begun), then its commit, or its
// rollback on failure.
template <class Graph, class Factor>
Status FactorizationDriver<Graph, Factor>::rowUpdateAndCommit(const Index* position_of,
                                                              Index new_columns) {
  Status s = addRowsOfAddedFactors(position_of, new_columns);
  if (s == Status::Ok) s = factor_.finishRowUpdate();
  if (s == Status::Ok) {
    factor_.commit();
  } else {
    factor_.rollback();
  }
  return s;
}

template <class Graph, class Factor>
Status FactorizationDriver<Graph, Factor>::factorizeWithRetry(
    Ordering& ordering, bool full, bool allow_top_reorder, Index new_columns,
    const Index* variable_at, const Index* position_of, const StagedVariables& relinearized,
    bool* top_reordered, UpdateResult& r) {
  if (likelyOutOfPool(full, relinearized.count, position_of) &&
      factor_.poolEnd() > factor_.liveBlocks()) {
    factor_.compact();
    r.compacted = true;
  }
  for (int attempt = 0;; ++attempt) {
    const Status s = factorizeOnce(ordering, full, allow_top_reorder, new_columns, variable_at,
                                   position_of, relinearized, top_reordered);
    if (s == Status::Ok) return s;
    // A full pool is often only garbage left by earlier updates: squeeze it out and try once more.
    if (s != Status::CapacityExhausted || attempt > 0) return s;
    factor_.compact();
    r.compacted = true;
  }
}

// Compacting before an update that would probably not fit saves the attempt that would fail (work
// of nearly the update's own size, thrown away). A full refactorization stages about the live
// factor again (a quarter more for a fresh order's fill), a loop closure or a relinearization at
// most about what the largest such update so far staged. An odometry update (the last columns
// only) is never compacted ahead: its need is tiny, and its cost must not depend on the pool's
// fill.
template <class Graph, class Factor>
bool FactorizationDriver<Graph, Factor>::likelyOutOfPool(bool full, Index relinearized,
                                                         const Index* position_of) const {
  const Index live = factor_.liveBlocks();
  const Index need = full ? live + live / 4 : largest_staging_;
  if (factor_.poolEnd() + need <= factor_.poolCapacity()) return false;  // the common case
  return full || relinearized > 0 || reachesBack(position_of);
}

// One attempt: a full refactorization, a reordered update of the affected top, or the plain
// update in the current order. The reordered update writes the fresh order to the inactive buffer.
template <class Graph, class Factor>
Status FactorizationDriver<Graph, Factor>::factorizeOnce(Ordering& ordering, bool full,
                                                         bool allow_top_reorder, Index new_columns,
                                                         const Index* variable_at,
                                                         const Index* position_of,
                                                         const StagedVariables& relinearized,
                                                         bool* top_reordered) {
  *top_reordered = false;
  factor_.beginUpdate(new_columns, full, variable_at);
  // A full refactorization in the active order (a reordering reads the other buffer) keeps the
  // structure of every column outside the etree paths of this update's factors.
  if (full && variable_at == ordering.variableAt()) {
    factor_.keepUnchangedStructures();
    visitAddedFactorColumns(position_of,
                            [this](Index column) { factor_.markStructureChanged(column); });
  }
  if (!full && relinearized.count == 0 && options_.row_updates && reachesBack(position_of)) {
    return rowUpdateAndCommit(position_of, new_columns);
  }
  if (!full) markAffectedColumns(position_of, relinearized);
  // (Not over a prepared ordering, which it would overwrite: the update that starts a spread
  // reordering keeps one for it.)
  if (!full && allow_top_reorder && options_.reorder_affected_top && !ordering.prepared() &&
      factor_.affectedTopSize() - new_columns >= options_.reorder_top_min_columns) {
    const Index num_last = collectLastColumns(position_of, new_columns);
    const Status s =
        factor_.factorizeReordered(graph_, ordering.colamd(), a_.last_list, num_last, variable_at,
                                   ordering.otherVariableAt(), ordering.otherPositionOf());
    if (s == Status::Ok) {
      factor_.commit();
      *top_reordered = true;
      return s;
    }
    factor_.rollback();
    // No ordering workspace for this top: the plain update below still works.
    if (s != Status::WorkspaceExhausted) return s;
    factor_.beginUpdate(new_columns, false);
    markAffectedColumns(position_of, relinearized);
  }
  const Status s = factor_.factorize(graph_, variable_at, position_of);
  if (s == Status::Ok) {
    factor_.commit();
  } else {
    factor_.rollback();
  }
  return s;
}

// The columns a reordered update keeps last: the existing variables of the added factors and the
// newest existing pose (ascending), then the added poses, newest last, so that the next odometry
// factor again touches only the last columns.
template <class Graph, class Factor>
Index FactorizationDriver<Graph, Factor>::collectLastColumns(const Index* position_of,
                                                             Index new_columns) {
  const Index first_new = factor_.columns();
  Index count = 0;
  auto add = [&](Index position) {
    if (position < first_new && a_.in_last[position] == 0) {
      a_.in_last[position] = 1;
      a_.last_list[count++] = position;
    }
  };
  visitAddedFactorColumns(position_of, add);
  if (first_new > 0) add(position_of[first_new - 1]);
  std::sort(a_.last_list, a_.last_list + count);
  for (Index i = 0; i < count; ++i) a_.in_last[a_.last_list[i]] = 0;
  for (Index k = first_new; k < first_new + new_columns; ++k) a_.last_list[count++] = k;
  return count;
}

// Whether an added factor touches a column before the newest committed one (a loop closure).
// Only then is the path long enough for the row update to pay: an odometry step touches the last
// two columns, and recomputing those is cheaper than whitening and rotating (on the Cortex-M7
// about 6,100 against 9,000 instructions per step).
template <class Graph, class Factor>
bool FactorizationDriver<Graph, Factor>::reachesBack(const Index* position_of) const {
  return addedLoopClosures(position_of) > 0;
}

template <class Graph, class Factor>
Index FactorizationDriver<Graph, Factor>::addedLoopClosures(const Index* position_of) const {
  Index count = 0;
  for (Index f = first_new_factor_; f < newFactorsEnd(); ++f) {
    if (factorReachesBack(f, position_of)) ++count;
  }
  return count;
}

// Whether factor f touches a column before the newest committed one.
template <class Graph, class Factor>
bool FactorizationDriver<Graph, Factor>::factorReachesBack(Index f,
                                                           const Index* position_of) const {
  const Index newest_committed = factor_.columns() - 1;
  if (position_of[graph_.firstVariable(f)] < newest_committed) return true;
  const Index second = graph_.secondVariable(f);
  return second != kNoIndex && position_of[second] < newest_committed;
}

// The factors that reach back (loop closures) go in groups of up to kJointFactors, each group
// rotated together along the parts of their paths they share; the rest (odometry: the last two
// columns) one by one. With mixed block sizes, or more than one added column, the seeding factors
// go first (see seedAddedColumns).
template <class Graph, class Factor>
Status FactorizationDriver<Graph, Factor>::addRowsOfAddedFactors(const Index* position_of,
                                                                 Index new_columns) {
  using FactorRows = typename Factor::FactorRows;
  Index num_seeds = 0;
  // One size and one added column (an online step): the first factor to reach it seeds it.
  if (!Factor::kUniform || new_columns > 1) {
    const Status s = seedAddedColumns(position_of, &num_seeds);
    if (s != Status::Ok) return s;
  }
  struct Whitened {
    Index positions[2];
    typename Factor::Block rows[2];
    FactorRows rows_of;
  };
  Whitened whitened[Factor::kJointFactors];
  const FactorRows* group[Factor::kJointFactors];
  int pending = 0;  // reaching-back factors whitened, waiting for the group to fill
  auto addPending = [&] {
    const Status s =
        pending == 1 ? factor_.addFactorRows(*group[0]) : factor_.addFactorRows(group, pending);
    pending = 0;
    return s;
  };
  Index next_seed = 0;
  for (Index f = first_new_factor_; f < newFactorsEnd(); ++f) {
    if (next_seed < num_seeds && a_.last_list[next_seed] == f) {  // rotated in already
      ++next_seed;
      continue;
    }
    Whitened& w = whitened[pending];
    w.rows_of.count = graph_.whitenedRows(f, position_of, w.positions, w.rows, &w.rows_of.rhs);
    w.rows_of.positions = w.positions;
    w.rows_of.rows_transposed = w.rows;
    Status s = Status::Ok;
    if (!factorReachesBack(f, position_of)) {
      s = factor_.addFactorRows(w.rows_of);
    } else {
      group[pending++] = &w.rows_of;
      if (pending == Factor::kJointFactors) s = addPending();
    }
    if (s != Status::Ok) return s;
  }
  return pending > 0 ? addPending() : Status::Ok;
}

// An added column starts empty, and the first rows rotated into it must have its full rank: a
// factor with fewer error rows than the column is wide (a point observation into a pose) leaves a
// zero pivot. The validator guarantees each added variable a factor that fixes it alone (a
// between factor or a prior for a pose, an observation for a landmark), with as many error rows
// as the variable has degrees of freedom. Such factors go first, one by one, each once it holds a
// single added column not seeded yet (an observation of an added landmark from the added pose
// waits for the pose's between factor; a between factor of two added poses, for one of them to
// be seeded). Their indices go to last_list, ascending, for addRowsOfAddedFactors to skip.
template <class Graph, class Factor>
Status FactorizationDriver<Graph, Factor>::seedAddedColumns(const Index* position_of,
                                                            Index* num_seeds) {
  Index count = 0;
  Status s = Status::Ok;
  for (bool progress = true; progress && s == Status::Ok;) {
    progress = false;
    for (Index f = first_new_factor_; s == Status::Ok && f < newFactorsEnd(); ++f) {
      if (std::find(a_.last_list, a_.last_list + count, f) != a_.last_list + count) continue;
      if (!seedsColumns(f, position_of)) continue;
      a_.last_list[count++] = f;
      s = addRowsAlone(f, position_of);
      progress = true;
    }
  }
  std::sort(a_.last_list, a_.last_list + count);
  // The marks go back to zero (a rejected update included).
  for (Index f = first_new_factor_; f < newFactorsEnd(); ++f) {
    a_.in_last[position_of[graph_.firstVariable(f)]] = 0;
    const Index second = graph_.secondVariable(f);
    if (second != kNoIndex) a_.in_last[position_of[second]] = 0;
  }
  *num_seeds = count;
  return s;
}

// Whether factor f can seed now: exactly one added column it holds is not seeded yet, and f's
// rows give it full rank (a factor of m rows has rank m in all: between two unseeded added poses
// it can seed only one of them, the other would get no rank). If so, marks that column seeded.
template <class Graph, class Factor>
bool FactorizationDriver<Graph, Factor>::seedsColumns(Index f, const Index* position_of) {
  using Adapter = GraphAdapter<Graph>;
  const Index variables[2] = {graph_.firstVariable(f), graph_.secondVariable(f)};
  Index unseeded = kNoIndex;
  for (const Index v : variables) {
    if (v == kNoIndex || position_of[v] < factor_.columns() || a_.in_last[position_of[v]] != 0) {
      continue;  // no variable, a committed column, or one seeded already
    }
    if (unseeded != kNoIndex) return false;  // two unseeded columns: wait for one to be seeded
    unseeded = v;
  }
  if (unseeded == kNoIndex) return false;
  if (Adapter::dofOfKind(Adapter::kindOf(graph_, unseeded)) > Adapter::errorRows(graph_, f)) {
    return false;
  }
  a_.in_last[position_of[unseeded]] = 1;
  return true;
}

template <class Graph, class Factor>
Status FactorizationDriver<Graph, Factor>::addRowsAlone(Index f, const Index* position_of) {
  Index positions[2];
  typename Factor::Block rows[2];
  typename Factor::FactorRows rows_of;
  rows_of.count = graph_.whitenedRows(f, position_of, positions, rows, &rows_of.rhs);
  rows_of.positions = positions;
  rows_of.rows_transposed = rows;
  return factor_.addFactorRows(rows_of);
}

template <class Graph, class Factor>
void FactorizationDriver<Graph, Factor>::markAffectedColumns(const Index* position_of,
                                                             const StagedVariables& relinearized) {
  visitAddedFactorColumns(position_of, [this](Index column) { factor_.markChanged(column); });
  // A relinearized variable changes its own column of Lambda and those of its neighbours.
  ColumnMarker<Factor> marker(factor_, position_of);
  for (Index i = 0; i < relinearized.count; ++i) {
    const Index v = relinearized.list[i];
    factor_.markChanged(position_of[v]);
    graph_.visitNeighbours(v, marker);
  }
}

// Every model's graph and factor.
template class FactorizationDriver<FactorGraph<Slam2D>, IncrementalCholesky<3, 2>>;
template class FactorizationDriver<FactorGraph<Slam3D>, IncrementalCholesky<6, 3>>;
template class FactorizationDriver<FactorGraph<PoseSlam2D>, IncrementalCholesky<3>>;
template class FactorizationDriver<FactorGraph<PoseSlam3D>, IncrementalCholesky<6>>;

}  // namespace lslam
