#pragma once
// The factor graph of any model (slam_2d.h, slam_3d.h) as the solver holds it: each variable's
// linearization point, each factor's measurement and information, and per variable the list of
// factors that touch it. It is the InformationSource of
// IncrementalCholesky<ModelBlockSizes<Model>...>, a column of Lambda is linearized from the factors
// on demand, and every change belongs to an update that is committed or rolled back as a whole, a
// rollback restoring every stored value bit for bit (variables and factors are appended;
// relinearizations and a disabled prior are staged).
//
// Variable kinds: the model's first variable kind is the pose, the second (if any) the landmark;
// the storage gives each its own capacity. Every variable has its kind (one byte, in an array the
// factorization reads as CholeskyArrays::variable_kind) and an offset into a pool of doubles that
// holds its value in StoredValue form (SE2: x y theta; SE3: qx qy qz qw x y z; points: their
// coordinates). The pool is sized exactly from the per-kind capacities.
//
// Factors: a kind (one byte), one or two variables and an offset into a pool of doubles holding
// the measurement (StoredValue form) followed by the information matrix, kErrorDim^2 doubles,
// column-major, stored as its symmetric part (symmetrize). Each factor takes
// exactly its kind's count (kFactorValues<F>), no slot is padded to the largest kind.
//
// No linearization cache: every factor is linearized afresh when a column asks (a cache would
// spare a reordering most linearizations, at a Jacobian pair per factor of RAM). whitenedRows gives
// the rows of the row update.
//
// Every definition that is not a member template is in factor_graph.cpp, compiled for every
// model.
#include <cstdint>
#include <type_traits>

#include "lslam/assert.h"
#include "lslam/eigen.h"
#include "lslam/factors/information.h"
#include "lslam/geometry/point.h"
#include "lslam/geometry/se2.h"
#include "lslam/geometry/se3.h"
#include "lslam/linear/block_sizes.h"
#include "lslam/linear/index.h"
#include "lslam/linear/information_source.h"
#include "lslam/models/model_traits.h"
#include "lslam/type_list.h"

namespace lslam {

// ---- Values as doubles ------------------------------------------------------------------------
// StoredValue<T>: kSize doubles; store(x, out) writes them, load(in) rebuilds x bit for bit.

template <class T>
struct StoredValue;

template <>
struct StoredValue<SE2> {
  static constexpr int kSize = 3;  // x y theta
  static void store(const SE2& x, double* out) noexcept {
    out[0] = x.x();
    out[1] = x.y();
    out[2] = x.theta();
  }
  // theta was stored wrapped, and wrapping a wrapped angle returns it unchanged.
  static SE2 load(const double* in) noexcept { return SE2(in[0], in[1], in[2]); }
};

template <>
struct StoredValue<SE3> {
  static constexpr int kSize = 7;  // qx qy qz qw x y z (Eigen's coefficient order, translation)
  static void store(const SE3& x, double* out) noexcept {
    const Eigen::Quaterniond& q = x.rotation().quaternion();
    out[0] = q.x();
    out[1] = q.y();
    out[2] = q.z();
    out[3] = q.w();
    out[4] = x.translation().x();
    out[5] = x.translation().y();
    out[6] = x.translation().z();
  }
  static SE3 load(const double* in) noexcept {
    return SE3(SO3(Eigen::Quaterniond(in[3], in[0], in[1], in[2])), Vec3(in[4], in[5], in[6]));
  }
};

template <int N>
struct StoredValue<Point<N>> {
  static constexpr int kSize = N;
  static void store(const Point<N>& x, double* out) noexcept {
    for (int i = 0; i < N; ++i) out[i] = x.vector()(i);
  }
  static Point<N> load(const double* in) noexcept {
    return Point<N>(Eigen::Map<const Eigen::Matrix<double, N, 1>>(in));
  }
};

template <int N, int Options, int MaxRows, int MaxCols>
struct StoredValue<Eigen::Matrix<double, N, 1, Options, MaxRows, MaxCols>> {
  using Vector = Eigen::Matrix<double, N, 1, Options, MaxRows, MaxCols>;
  static constexpr int kSize = N;
  static void store(const Vector& x, double* out) noexcept {
    for (int i = 0; i < N; ++i) out[i] = x(i);
  }
  static Vector load(const double* in) noexcept { return Vector(Eigen::Map<const Vector>(in)); }
};

// The doubles a factor of kind F takes in the factor pool: its measurement, then its information.
template <class F>
inline constexpr Index kFactorValues =
    StoredValue<typename F::Measurement>::kSize + F::kErrorDim* F::kErrorDim;

namespace detail {

// Per variable kind: the doubles of a value.
template <class List>
struct VariableTables;
template <class... V>
struct VariableTables<TypeList<V...>> {
  static constexpr int kValueSize[sizeof...(V)] = {StoredValue<V>::kSize...};
};

// Per factor kind: its doubles and its variables; the largest information matrix.
template <class List>
struct FactorTables;
template <class... F>
struct FactorTables<TypeList<F...>> {
  static constexpr Index kFactorSize[sizeof...(F)] = {kFactorValues<F>...};
  static constexpr int kMeasurementSize[sizeof...(F)] = {
      StoredValue<typename F::Measurement>::kSize...};
  static constexpr int kArity[sizeof...(F)] = {F::Variables::kSize...};
  static constexpr int kMaxInformation = [] {
    int m = 0;
    ((m = F::kErrorDim * F::kErrorDim > m ? F::kErrorDim * F::kErrorDim : m), ...);
    return m;
  }();
  static constexpr int kMaxErrorDim = [] {
    int m = 0;
    ((m = F::kErrorDim > m ? F::kErrorDim : m), ...);
    return m;
  }();
  static constexpr int kMinErrorDim = [] {
    int m = kMaxErrorDim;
    ((m = F::kErrorDim < m ? F::kErrorDim : m), ...);
    return m;
  }();
};

// The linear algebra types of a list of block sizes.
template <class Sizes>
struct LinearTypesOf;
template <int... S>
struct LinearTypesOf<BlockSizes<S...>> {
  using Source = InformationSource<S...>;
  using Accumulator = ColumnAccumulator<S...>;
  using Later = LaterDiagonals<S...>;
};

}  // namespace detail

// ---- Memory -----------------------------------------------------------------------------------

// The variable kinds a graph holds: pose and landmark.
inline constexpr int kMaxVariableKinds = 2;

// The arrays a FactorGraph works in, owned by whoever holds the memory (see
// StaticFactorGraphStorage). Per variable: max_variables (the sum of max_of_kind); the value
// pools: max_values doubles (each kind's capacity times its value size); per factor: max_factors;
// the factor pool: max_factor_values doubles; the factor-list links: 2 * max_factors.
struct FactorGraphArrays {
  Index max_of_kind[kMaxVariableKinds] = {};
  Index max_variables = 0;
  Index max_values = 0;
  Index max_factors = 0;
  Index max_factor_values = 0;
  double* values = nullptr;               // max_values: committed linearization points
  double* staged_values = nullptr;        // max_values: staged ones, at the same offsets
  std::uint8_t* variable_kind = nullptr;  // max_variables
  Index* value_offset = nullptr;          // max_variables
  std::uint32_t* staged = nullptr;        // max_variables: the update stamp of a staged point
  Index* staged_list = nullptr;           // max_variables
  Index* first_entry = nullptr;           // max_variables: head of the variable's factor list
  std::uint8_t* factor_kind = nullptr;    // max_factors
  Index* first_variable = nullptr;        // max_factors
  Index* second_variable = nullptr;       // max_factors (kNoIndex for a unary factor)
  Index* factor_offset = nullptr;         // max_factors
  double* factor_values = nullptr;        // max_factor_values
  Index* entry_factor = nullptr;          // 2 * max_factors: the factor-list links
  Index* next_entry = nullptr;            // 2 * max_factors
};

// ---- The graph --------------------------------------------------------------------------------

template <class Model>
class FactorGraph final : public detail::LinearTypesOf<ModelBlockSizes<Model>>::Source {
 public:
  using Variables = typename Model::Variables;
  using Factors = typename Model::Factors;
  using Sizes = ModelBlockSizes<Model>;
  using Accumulator = typename detail::LinearTypesOf<Sizes>::Accumulator;
  using Later = typename detail::LinearTypesOf<Sizes>::Later;
  static constexpr int kMax = Sizes::kMax;
  using Delta = Eigen::Matrix<double, kMax, 1>;
  static_assert(detail::FactorTables<Factors>::kMaxErrorDim <= kMax,
                "a factor's whitened rows fit a kMax x kMax block (whitenedRows)");
  using RowBlock = Eigen::Matrix<double, kMax, kMax>;
  static_assert(Variables::kSize >= 1 && Variables::kSize <= kMaxVariableKinds,
                "a pose kind and at most one landmark kind");

  explicit FactorGraph(const FactorGraphArrays& arrays);

  // ---- Sizes and capacities: a caller checks them before adding (CapacityExhausted).
  Index variables() const { return num_variables_; }
  Index maxVariables() const { return a_.max_variables; }
  Index variablesOfKind(int kind) const { return num_of_kind_[kind]; }
  Index maxVariablesOfKind(int kind) const { return a_.max_of_kind[kind]; }
  Index freeVariablesOfKind(int kind) const { return a_.max_of_kind[kind] - num_of_kind_[kind]; }
  Index factors() const { return num_factors_; }
  Index maxFactors() const { return a_.max_factors; }
  Index freeFactors() const { return a_.max_factors - num_factors_; }
  Index factorValuesUsed() const { return num_factor_values_; }
  Index maxFactorValues() const { return a_.max_factor_values; }
  Index freeFactorValues() const { return a_.max_factor_values - num_factor_values_; }
  // The doubles one factor of a kind takes (kFactorValues of that kind).
  static constexpr Index factorValuesOfKind(int kind) {
    return detail::FactorTables<Factors>::kFactorSize[kind];
  }
  // The variables a factor of a kind connects (1 or 2).
  static constexpr int arityOfKind(int kind) { return detail::FactorTables<Factors>::kArity[kind]; }
  template <class V>
  bool canAddVariable() const {
    return freeVariablesOfKind(kVariableKind<Model, V>) > 0;
  }
  template <class F>
  bool canAddFactor() const {
    return freeFactors() > 0 && freeFactorValues() >= kFactorValues<F>;
  }

  // ---- Updates.
  void beginUpdate();
  // Appends a variable of kind V at `initial` (asserts canAddVariable<V>()).
  template <class V>
  Index addVariable(const V& initial) {
    const Index v = appendVariable(kVariableKind<Model, V>);
    StoredValue<V>::store(initial, a_.values + a_.value_offset[v]);
    return v;
  }
  // Appends a factor of kind F on `first` and `second` (kNoIndex for a unary kind), of the kinds F
  // names, with information stored as its symmetric part (asserts canAddFactor<F>()). The inputs
  // are the caller's to validate (F::validate).
  template <class F>
  Index addFactor(Index first, Index second, const typename F::Measurement& z,
                  const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>& information) {
    static_assert(F::Variables::kSize == 1 || F::Variables::kSize == 2, "unary or binary");
    using A = TypeAtT<0, typename F::Variables>;
    LSLAM_ASSERT(first >= 0 && first < num_variables_ &&
                 a_.variable_kind[first] == (kVariableKind<Model, A>));
    if constexpr (F::Variables::kSize == 2) {
      using B = TypeAtT<1, typename F::Variables>;
      LSLAM_ASSERT(second >= 0 && second < num_variables_ && second != first &&
                   a_.variable_kind[second] == (kVariableKind<Model, B>));
    } else {
      LSLAM_ASSERT(second == kNoIndex);
    }
    const Index f = appendFactor(kFactorKind<Model, F>, first, second);
    storeFactorValues<F>(f, z, information);
    return f;
  }
  // Takes a committed unary factor (a prior) out of the problem: its information becomes zero, so
  // that it adds nothing to Lambda, eta or the error (it stays in its variable's factor list). At
  // most one per update; a rollback restores it. assembleColumnChange subtracts its old share.
  void disablePrior(Index factor);
  // Outside an update: writes (z, information) over committed factor `into` and takes out the
  // newest factor, which must be of the same kind on the same variables (Smoother::addFolded: the
  // newest one's measurement merged into `into`'s). The graph then holds one factor where the
  // factorization added two; see addFolded for what that trades.
  template <class F>
  void foldNewestFactor(Index into, const typename F::Measurement& z,
                        const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>& information) {
    const Index newest = num_factors_ - 1;
    LSLAM_ASSERT(!in_update_ && into >= 0 && into < newest &&
                 a_.factor_kind[into] == (kFactorKind<Model, F>)&&a_.factor_kind[newest] ==
                     a_.factor_kind[into] &&
                 a_.first_variable[newest] == a_.first_variable[into] &&
                 a_.second_variable[newest] == a_.second_variable[into]);
    storeFactorValues<F>(into, z, information);
    takeOutNewestFactor();
  }
  // Stages `point` as the linearization point of v (of kind V) until commit.
  template <class V>
  void relinearize(Index v, const V& point) {
    LSLAM_ASSERT(in_update_ && v >= 0 && v < num_variables_ &&
                 a_.variable_kind[v] == (kVariableKind<Model, V>));
    StoredValue<V>::store(point, a_.staged_values + a_.value_offset[v]);
    stage(v);
  }
  // Stages linearizationPoint(v).retract(delta.head(kDof)) for v's kind (from the current point:
  // calling it twice in one update moves twice).
  void relinearizeBy(Index v, const Delta& delta);
  // Forgets the points staged in this update (its added variables and factors stay).
  void unstageRelinearization();
  void commit();
  void rollback();
  bool inUpdate() const { return in_update_; }

  // ---- Variables.
  int variableKind(Index v) const { return a_.variable_kind[v]; }
  // One byte per variable: CholeskyArrays::variable_kind.
  const std::uint8_t* variableKinds() const { return a_.variable_kind; }
  // The point v (of kind V) is linearized at: the staged one inside an update, if any.
  template <class V>
  V linearizationPoint(Index v) const {
    LSLAM_ASSERT(v >= 0 && v < num_variables_ && a_.variable_kind[v] == (kVariableKind<Model, V>));
    return StoredValue<V>::load(valuesOf(v, false));
  }
  // linearizationPoint(v).retract(delta.head(kDof)): the estimate of v for its solution delta.
  template <class V>
  V estimate(Index v, const Delta& delta) const {
    return linearizationPoint<V>(v).retract(delta.template head<V::kDof>());
  }
  // The doubles of v's linearization point (StoredValue form; the staged ones inside an update).
  const double* variableValues(Index v) const { return valuesOf(v, false); }
  bool isStaged(Index v) const { return in_update_ && a_.staged[v] == stamp_; }

  // ---- Factors. Iteration over those touching a variable: for (e = firstEntry(v); e !=
  // kNoIndex; e = nextEntry(e)) { f = entryFactor(e); }, or forEachFactor(v, fn).
  Index firstEntry(Index v) const { return a_.first_entry[v]; }
  Index nextEntry(Index entry) const { return a_.next_entry[entry]; }
  Index entryFactor(Index entry) const { return a_.entry_factor[entry]; }
  template <class Fn>
  void forEachFactor(Index v, Fn&& fn) const {
    for (Index e = a_.first_entry[v]; e != kNoIndex; e = a_.next_entry[e]) fn(a_.entry_factor[e]);
  }
  int factorKind(Index f) const { return a_.factor_kind[f]; }
  Index firstVariable(Index f) const { return a_.first_variable[f]; }
  Index secondVariable(Index f) const { return a_.second_variable[f]; }
  // The factor's doubles: measurement, then information (see above).
  const double* factorValues(Index f) const { return a_.factor_values + a_.factor_offset[f]; }
  template <class F>
  typename F::Measurement measurement(Index f) const {
    LSLAM_ASSERT(a_.factor_kind[f] == (kFactorKind<Model, F>));
    return StoredValue<typename F::Measurement>::load(factorValues(f));
  }
  template <class F>
  Eigen::Matrix<double, F::kErrorDim, F::kErrorDim> information(Index f) const {
    LSLAM_ASSERT(a_.factor_kind[f] == (kFactorKind<Model, F>));
    using Matrix = Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>;
    return Matrix(
        Eigen::Map<const Matrix>(factorValues(f) + StoredValue<typename F::Measurement>::kSize));
  }

  // The row update's rows of factor f: with Omega = L L^T, for each of its variables v the block
  // J_v^T L at positions[i] = position[v] (dof(v) x kErrorDim in the top-left corner, zero
  // elsewhere), and rhs = -L^T e (its first kErrorDim entries), at the current linearization
  // points; returns the count (1 or 2). Lambda gains sum J^T Omega J, eta -J^T Omega e.
  Index whitenedRows(Index f, const Index* position, Index* positions, RowBlock* rows_transposed,
                     Delta* rhs) const;

  // Whitened squared error e^T Omega e of one factor at the current linearization points.
  double factorChi2(Index f) const;
  // The sum of factorChi2 over every factor.
  double chi2() const;

  // ---- InformationSource.
  void visitNeighbours(Index variable, NeighbourVisitor& visitor) const override;
  void assembleColumnChange(Index variable, const Index* position, Accumulator& acc) const override;
  void assembleColumn(Index variable, const Index* position, Accumulator& acc,
                      Later& later) const override;

 private:
  static constexpr int kMaxInformation = detail::FactorTables<Factors>::kMaxInformation;

  // The committed point's doubles, or the current ones (staged inside an update).
  const double* valuesOf(Index v, bool committed) const {
    return ((committed || !isStaged(v)) ? a_.values : a_.staged_values) + a_.value_offset[v];
  }
  // The factor's information matrix in the pool.
  const double* factorInformation(Index f) const;
  Index otherVariable(Index f, Index v) const {
    return a_.first_variable[f] == v ? a_.second_variable[f] : a_.first_variable[f];
  }
  Index appendVariable(int kind);
  Index appendFactor(int kind, Index first, Index second);
  void link(Index v, Index f);
  // Writes factor f's measurement and information (stored as its symmetric part).
  template <class F>
  void storeFactorValues(Index f, const typename F::Measurement& z,
                         const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>& information) {
    double* values = a_.factor_values + a_.factor_offset[f];
    StoredValue<typename F::Measurement>::store(z, values);
    Eigen::Matrix<double, F::kErrorDim, F::kErrorDim> omega = information;
    symmetrize(omega);
    Eigen::Map<Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>>(
        values + StoredValue<typename F::Measurement>::kSize) = omega;
  }
  // Unlinks and forgets the newest committed factor (outside an update).
  void takeOutNewestFactor();
  void stage(Index v);
  // Adds sign times factor f's share of column `variable` and of eta, linearized at the committed
  // points (committed) or the current ones, with the information at `information`. With `later`
  // (a full assembly), a binary factor whose other variable comes earlier in position is skipped
  // (its earlier column assembled it), and one whose other variable comes later sends that
  // variable's diagonal block and eta to `later`.
  void addShare(Index f, Index variable, const Index* position, bool committed,
                const double* information, double sign, Accumulator& acc, Later* later) const;

  FactorGraphArrays a_;
  Index num_variables_ = 0;
  Index num_of_kind_[kMaxVariableKinds] = {};
  Index num_values_ = 0;
  Index num_factors_ = 0;
  Index num_factor_values_ = 0;
  Index num_entries_ = 0;
  Index committed_variables_ = 0;
  Index committed_of_kind_[kMaxVariableKinds] = {};
  Index committed_values_ = 0;
  Index committed_factors_ = 0;
  Index committed_factor_values_ = 0;
  Index committed_entries_ = 0;
  std::uint32_t stamp_ = 1;
  Index staged_count_ = 0;
  Index disabled_ = kNoIndex;                          // the prior disabled by the update
  double disabled_information_[kMaxInformation] = {};  // ...and its information before
  bool in_update_ = false;
};

// Memory for a FactorGraph<Model>: MaxPoses variables of the model's first kind, MaxLandmarks of
// its second (0 for a model of one kind), MaxFactors factors and MaxFactorValues doubles for their
// measurements and information (sum kFactorValues<F> over the factors to be held).
template <class Model, Index MaxPoses, Index MaxLandmarks, Index MaxFactors, Index MaxFactorValues>
class StaticFactorGraphStorage {
  using Variables = typename Model::Variables;
  using Tables = detail::VariableTables<Variables>;

 public:
  static_assert(MaxPoses > 0 && MaxLandmarks >= 0 && MaxFactors > 0 && MaxFactorValues > 0,
                "capacities");
  static_assert(Variables::kSize == 2 || MaxLandmarks == 0, "a model without landmarks");
  static constexpr Index kMaxVariables = MaxPoses + MaxLandmarks;
  static constexpr Index kValues =
      MaxPoses * Tables::kValueSize[0] +
      (Variables::kSize == 2 ? MaxLandmarks * Tables::kValueSize[Variables::kSize - 1] : 0);

  FactorGraphArrays arrays() {
    FactorGraphArrays a;
    a.max_of_kind[0] = MaxPoses;
    a.max_of_kind[1] = MaxLandmarks;
    a.max_variables = kMaxVariables;
    a.max_values = kValues;
    a.max_factors = MaxFactors;
    a.max_factor_values = MaxFactorValues;
    a.values = values_;
    a.staged_values = staged_values_;
    a.variable_kind = variable_kind_;
    a.value_offset = value_offset_;
    a.staged = staged_;
    a.staged_list = staged_list_;
    a.first_entry = first_entry_;
    a.factor_kind = factor_kind_;
    a.first_variable = first_variable_;
    a.second_variable = second_variable_;
    a.factor_offset = factor_offset_;
    a.factor_values = factor_values_;
    a.entry_factor = entry_factor_;
    a.next_entry = next_entry_;
    return a;
  }

 private:
  double values_[kValues];
  double staged_values_[kValues];
  std::uint8_t variable_kind_[kMaxVariables];
  Index value_offset_[kMaxVariables];
  std::uint32_t staged_[kMaxVariables];
  Index staged_list_[kMaxVariables];
  Index first_entry_[kMaxVariables];
  std::uint8_t factor_kind_[MaxFactors];
  Index first_variable_[MaxFactors];
  Index second_variable_[MaxFactors];
  Index factor_offset_[MaxFactors];
  double factor_values_[MaxFactorValues];
  Index entry_factor_[2 * MaxFactors];
  Index next_entry_[2 * MaxFactors];
};

}  // namespace lslam
