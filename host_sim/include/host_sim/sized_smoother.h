#pragma once
// A smoother whose memory is sized at run time (host only): the arrays of a StaticSmoother, held
// in std::vector buffers allocated once at construction from SmootherCapacities, under the same
// size-erased lslam::Smoother<Model>. Every buffer is zeroed at construction, as the robot's .bss
// is before main(), so that no timed step pays the first touch of a page.
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <type_traits>
#include <vector>

#include "lslam/solver/smoother.h"

namespace lslam::sim {

// A smoother's capacities, as StaticSmoother's template parameters: poses and landmarks
// (variables of the model's two kinds), factors (the anchor takes one), factor_values (doubles:
// kFactorValues<F> per factor), factor_blocks (the Cholesky factor's block pool: the live factor
// and the columns an update stages beside it) and factor_block_values (doubles for the pool's
// blocks, mixed block sizes only: r * c per block of r rows and c columns).
struct SmootherCapacities {
  Index poses = 0;
  Index landmarks = 0;
  Index factors = 0;
  Index factor_values = 0;
  Index factor_blocks = 0;
  Index factor_block_values = 0;
  // A second factor for spread reorderings (SolverOptions::spread_reorder_products) of this pool,
  // and the updates one may take; 0: none.
  Index spread_factor_blocks = 0;
  Index spread_updates = 0;

  bool operator==(const SmootherCapacities& o) const {
    return poses == o.poses && landmarks == o.landmarks && factors == o.factors &&
           factor_values == o.factor_values && factor_blocks == o.factor_blocks &&
           factor_block_values == o.factor_block_values &&
           spread_factor_blocks == o.spread_factor_blocks && spread_updates == o.spread_updates;
  }
  bool operator!=(const SmootherCapacities& o) const { return !(*this == o); }
};

namespace detail {

// The buffers of a SizedSmoother, a base class so that they exist before the smoother that points
// into them.
template <class Model>
class SizedSmootherStorage {
 protected:
  using Vector = typename SmootherArrays<Model>::Vector;
  using FactorArrays = typename Smoother<Model>::FactorArrays;
  using Block = typename FactorArrays::Block;
  static constexpr int kKinds = Model::Variables::kSize;
  static constexpr bool kUniform = ModelBlockSizes<Model>::kUniform;
  static constexpr std::size_t kSolutionAlign = 32;  // as StaticCholeskyStorageFor's solution

  explicit SizedSmootherStorage(const SmootherCapacities& c) : capacities_(c) {
    const Index vars = c.poses + c.landmarks;
    const auto n = [](Index count) { return static_cast<std::size_t>(count); };

    // The factor graph (StaticFactorGraphStorage).
    const int* value_size = lslam::detail::VariableTables<typename Model::Variables>::kValueSize;
    graph_.max_of_kind[0] = c.poses;
    graph_.max_of_kind[1] = c.landmarks;
    graph_.max_variables = vars;
    graph_.max_values = c.poses * value_size[0] + (kKinds == 2 ? c.landmarks * value_size[1] : 0);
    graph_.max_factors = c.factors;
    graph_.max_factor_values = c.factor_values;
    FactorGraphArrays& g = graph_;
    takeEach(doubles_, n(g.max_values), {&g.values, &g.staged_values});
    takeEach(bytes_, n(vars), {&g.variable_kind});
    takeEach(stamps_, n(vars), {&g.staged});
    takeEach(indices_, n(vars), {&g.value_offset, &g.staged_list, &g.first_entry});
    takeEach(bytes_, n(c.factors), {&g.factor_kind});
    takeEach(indices_, n(c.factors), {&g.first_variable, &g.second_variable, &g.factor_offset});
    takeEach(doubles_, n(c.factor_values), {&g.factor_values});
    takeEach(indices_, 2 * n(c.factors), {&g.entry_factor, &g.next_entry});

    // The Cholesky factor (StaticCholeskyStorageFor): columns are variables.
    takeFactor(factor_, vars, c.factor_blocks, c.factor_block_values);
    if (c.spread_factor_blocks > 0 && c.spread_updates > 0) {
      const Index values =
          kUniform ? 0 : c.spread_factor_blocks * FactorArrays::D * FactorArrays::D;
      takeFactor(spread_.factor, vars, c.spread_factor_blocks, values);
      SpreadReorderingArrays<Vector>& r = spread_.reordering;
      takeEach(indices_, n(vars), {&r.position_of, &r.variable_at, &r.relinearized});
      takeEach(vectors_, n(vars), {&r.relinearized_by});
      r.max_updates = c.spread_updates;
      takeEach(indices_, n(c.spread_updates) + 1, {&r.first_factor, &r.first_variable});
      takeEach(indices_, n(vars), {&r.driver.last_list});
      takeEach(bytes_, n(vars), {&r.driver.in_last});
    }

    // The ordering (StaticColamdStorage<2 * factors, factors, variables>).
    ordering_.max_nonzeros = 2 * n(c.factors);
    ordering_.max_rows = n(c.factors);
    ordering_.max_columns = n(vars);
    ordering_.a = take(ints_, colamdWorkspaceSize(ordering_.max_nonzeros, ordering_.max_rows,
                                                  ordering_.max_columns));
    ordering_.p = take(ints_, n(vars) + 1);

    // The id maps (StaticIdMapStorage), one per kind; a model of one kind keeps the smallest.
    const Index of_kind[2] = {c.poses, c.landmarks > 0 ? c.landmarks : 1};
    for (int k = 0; k < 2; ++k) {
      ids_[k].slots = idMapSlots(n(of_kind[k]));
      ids_[k].keys = take(ids_of_, ids_[k].slots);
      ids_[k].values = take(indices_, ids_[k].slots);
    }

    // The smoother's own arrays (detail::SmootherStorage).
    SmootherArrays<Model>& s = smoother_;
    takeEach(indices_, n(vars),
             {&s.position_of[0], &s.position_of[1], &s.variable_at[0], &s.variable_at[1],
              &s.ordering_parent, &s.ordering_count, &s.visited, &s.relinearize_list, &s.marked,
              &s.last_list});
    takeEach(ids_of_, n(vars), {&s.id_of});
    takeEach(vectors_, n(vars), {&s.delta});
    takeEach(bytes_, n(vars), {&s.relinearize_flag, &s.in_last});
    takeEach(bytes_, n(vars) + 1, {&s.held});
  }

  // The bytes of every buffer.
  std::size_t bufferBytes() const { return buffer_bytes_; }
  const SpreadArrays<Model>* spreadArrays() const {
    return capacities_.spread_factor_blocks > 0 && capacities_.spread_updates > 0 ? &spread_
                                                                                  : nullptr;
  }

  SmootherCapacities capacities_;
  SmootherArrays<Model> smoother_;
  FactorGraphArrays graph_;
  FactorArrays factor_;
  SpreadArrays<Model> spread_;
  ColamdArrays ordering_;
  IdMapArrays ids_[2];

 private:
  // The arrays of a Cholesky factor (StaticCholeskyStorageFor) of `vars` columns.
  void takeFactor(FactorArrays& a, Index vars, Index blocks, Index block_values) {
    const auto n = [](Index count) { return static_cast<std::size_t>(count); };
    a.max_columns = vars;
    a.max_blocks = blocks;
    if constexpr (kUniform) {
      takeEach(blocks_, n(blocks), {&a.blocks});
    } else {
      a.max_values = block_values;
      takeEach(doubles_, n(block_values), {&a.values});
      takeEach(indices_, n(blocks), {&a.offset});
      takeEach(bytes_, n(blocks), {&a.row_size});
    }
    takeEach(indices_, n(blocks), {&a.rows, &a.clique_entry});
    takeEach(blocks_, n(vars), {&a.diagonal, &a.staged_diagonal});
    for (auto& update_rows : a.update_rows) takeEach(blocks_, n(vars), {&update_rows});
    takeEach(vectors_, n(vars), {&a.d, &a.staged_d});
    takeEach(bytes_, n(vars), {&a.needs_solve});
    takeEach(stamps_, n(vars), {&a.queued, &a.mark});
    takeEach(indices_, n(vars),
             {&a.start, &a.count, &a.staged_start, &a.staged_count, &a.slot, &a.heap, &a.affected,
              &a.child_head, &a.child_next, &a.row_list, &a.scratch, &a.new_position, &a.top_order,
              &a.rank_of});
    takeEach(indices_, n(vars) + 1,
             {&a.first_child, &a.next_sibling, &a.prev_sibling, &a.clique_start});
    const std::size_t solution = n(vars) * lslam::detail::kSolutionStride<FactorArrays::D>;
    a.solution = takeAligned(solution);
  }

  // A zeroed buffer of `count` elements (at least one, so that every pointer is valid).
  template <class T>
  T* take(std::vector<std::vector<T>>& pool, std::size_t count) {
    pool.emplace_back(count > 0 ? count : 1, zero<T>());
    buffer_bytes_ += pool.back().size() * sizeof(T);
    return pool.back().data();
  }
  // A buffer of `count` for each of `targets`.
  template <class T>
  void takeEach(std::vector<std::vector<T>>& pool, std::size_t count,
                std::initializer_list<T**> targets) {
    for (T** target : targets) *target = take(pool, count);
  }
  // `count` zeroed doubles at a kSolutionAlign boundary.
  double* takeAligned(std::size_t count) {
    constexpr std::size_t kSlack = kSolutionAlign / sizeof(double);
    double* raw = take(doubles_, count + kSlack);
    void* p = raw;
    std::size_t space = (count + kSlack) * sizeof(double);
    return static_cast<double*>(std::align(kSolutionAlign, count * sizeof(double), p, space));
  }
  template <class T>
  static T zero() {
    if constexpr (std::is_arithmetic_v<T>) {
      return T{0};
    } else {
      return T::Zero();  // an Eigen type, whose default constructor leaves its values unset
    }
  }

  // Each buffer is its own vector: a vector's data does not move when another is added.
  std::vector<std::vector<double>> doubles_;
  std::vector<std::vector<Index>> indices_;
  std::vector<std::vector<int>> ints_;
  std::vector<std::vector<std::uint8_t>> bytes_;
  std::vector<std::vector<std::uint32_t>> stamps_;
  std::vector<std::vector<VariableId>> ids_of_;
  std::vector<std::vector<Block>> blocks_;
  std::vector<std::vector<Vector>> vectors_;
  std::size_t buffer_bytes_ = 0;
};

}  // namespace detail

// Smoother<Model> over buffers of the given capacities. bytes(): its buffers and the smoother
// object, the counterpart of a StaticSmoother's sizeof.
template <class Model>
class SizedSmoother : private detail::SizedSmootherStorage<Model>, public Smoother<Model> {
  using Storage = detail::SizedSmootherStorage<Model>;

 public:
  explicit SizedSmoother(const SmootherCapacities& capacities,
                         const SolverOptions& options = defaultSolverOptions<Model>())
      : Storage(capacities),
        Smoother<Model>(Storage::smoother_, Storage::graph_, Storage::factor_, Storage::ordering_,
                        Storage::ids_, options, Storage::spreadArrays()) {}

  const SmootherCapacities& capacities() const { return Storage::capacities_; }
  std::size_t bytes() const { return Storage::bufferBytes() + sizeof(SizedSmoother); }
};

}  // namespace lslam::sim
