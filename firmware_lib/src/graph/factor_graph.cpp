#include "lslam/graph/factor_graph.h"

#include <Eigen/Cholesky>
#include <cstring>
#include <type_traits>

#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

namespace lslam {

namespace {

template <int R, int C>
using Matrix = Eigen::Matrix<double, R, C>;

// A factor's share of Lambda and eta, for its variables a (first) and b (second, binary only):
// J_a^T Omega J_a, J_b^T Omega J_b, Lambda(b, a) = J_b^T Omega J_a and -J^T Omega e for each.
// Lambda(a, b) is always taken as the transpose of ba, so that both halves are the same bits.
template <class F, int Da, int Db>
struct Share {
  Matrix<Da, Da> aa;
  Matrix<Db, Db> bb;
  Matrix<Db, Da> ba;
  Matrix<Da, 1> eta_a;
  Matrix<Db, 1> eta_b;
};

template <class F>
using Measurement = typename F::Measurement;
template <class F>
using Omega = Matrix<F::kErrorDim, F::kErrorDim>;

template <class F>
Measurement<F> measurementAt(const double* values) {
  return StoredValue<Measurement<F>>::load(values);
}

template <class F>
Omega<F> informationAt(const double* information) {
  return Omega<F>(Eigen::Map<const Omega<F>>(information));
}

template <class F, class A>
void linearizeUnary(const double* values, const double* information, const A& xa,
                    Share<F, A::kDof, 1>& out) {
  Matrix<F::kErrorDim, A::kDof> ja;
  const Matrix<F::kErrorDim, 1> e = F::error(xa, measurementAt<F>(values), &ja);
  const Omega<F> omega = informationAt<F>(information);
  const Matrix<A::kDof, F::kErrorDim> jt_omega = ja.transpose() * omega;
  out.aa.noalias() = jt_omega * ja;
  out.eta_a.noalias() = -(jt_omega * e);
}

// Whether factor kind F brings its own linearization (F::linearize, see se2_factors.h).
template <class F, class = void>
struct HasLinearize : std::false_type {};
template <class F>
struct HasLinearize<F, std::void_t<decltype(&F::linearize)>> : std::true_type {};

template <class F, class A, class B>
void linearizeBinary(const double* values, const double* information, const A& xa, const B& xb,
                     Share<F, A::kDof, B::kDof>& out) {
  if constexpr (HasLinearize<F>::value) {
    F::linearize(xa, xb, measurementAt<F>(values), informationAt<F>(information), &out.aa, &out.bb,
                 &out.ba, &out.eta_a, &out.eta_b);
    return;
  }
  Matrix<F::kErrorDim, A::kDof> ja;
  Matrix<F::kErrorDim, B::kDof> jb;
  const Matrix<F::kErrorDim, 1> e = F::error(xa, xb, measurementAt<F>(values), &ja, &jb);
  const Omega<F> omega = informationAt<F>(information);
  const Matrix<F::kErrorDim, A::kDof> omega_ja = omega * ja;
  const Matrix<F::kErrorDim, B::kDof> omega_jb = omega * jb;
  const Matrix<F::kErrorDim, 1> omega_e = omega * e;
  out.aa.noalias() = ja.transpose() * omega_ja;
  out.bb.noalias() = jb.transpose() * omega_jb;
  out.ba.noalias() = jb.transpose() * omega_ja;
  out.eta_a.noalias() = -(ja.transpose() * omega_e);
  out.eta_b.noalias() = -(jb.transpose() * omega_e);
}

}  // namespace

template <class Model>
FactorGraph<Model>::FactorGraph(const FactorGraphArrays& arrays) : a_(arrays) {
  using Tables = detail::VariableTables<Variables>;
  Index total_values = 0;
  Index total_variables = 0;
  for (int k = 0; k < kMaxVariableKinds; ++k) {
    LSLAM_ASSERT(a_.max_of_kind[k] >= 0 && (k < Variables::kSize || a_.max_of_kind[k] == 0));
    if (k < Variables::kSize) total_values += a_.max_of_kind[k] * Tables::kValueSize[k];
    total_variables += a_.max_of_kind[k];
  }
  LSLAM_ASSERT(total_variables > 0 && a_.max_variables >= total_variables &&
               a_.max_values >= total_values && a_.max_factors > 0 && a_.max_factor_values > 0);
  LSLAM_ASSERT(a_.values != nullptr && a_.staged_values != nullptr && a_.variable_kind != nullptr &&
               a_.value_offset != nullptr && a_.staged != nullptr && a_.staged_list != nullptr &&
               a_.first_entry != nullptr && a_.factor_kind != nullptr &&
               a_.first_variable != nullptr && a_.second_variable != nullptr &&
               a_.factor_offset != nullptr && a_.factor_values != nullptr &&
               a_.entry_factor != nullptr && a_.next_entry != nullptr);
  std::memset(a_.staged, 0, sizeof(std::uint32_t) * static_cast<std::size_t>(a_.max_variables));
}

template <class Model>
void FactorGraph<Model>::beginUpdate() {
  LSLAM_ASSERT(!in_update_);
  in_update_ = true;
  if (++stamp_ == 0) {
    std::memset(a_.staged, 0, sizeof(std::uint32_t) * static_cast<std::size_t>(a_.max_variables));
    stamp_ = 1;
  }
  staged_count_ = 0;
}

template <class Model>
Index FactorGraph<Model>::appendVariable(int kind) {
  LSLAM_ASSERT(in_update_ && kind >= 0 && kind < Variables::kSize &&
               num_of_kind_[kind] < a_.max_of_kind[kind]);
  const int size = detail::VariableTables<Variables>::kValueSize[kind];
  // Per-kind capacities bound the pool: it cannot overflow while they hold.
  LSLAM_DEBUG_ASSERT(num_values_ + size <= a_.max_values);
  const Index v = num_variables_++;
  ++num_of_kind_[kind];
  a_.variable_kind[v] = static_cast<std::uint8_t>(kind);
  a_.value_offset[v] = num_values_;
  a_.first_entry[v] = kNoIndex;
  num_values_ += size;
  return v;
}

template <class Model>
void FactorGraph<Model>::link(Index v, Index f) {
  const Index e = num_entries_++;
  a_.entry_factor[e] = f;
  a_.next_entry[e] = a_.first_entry[v];
  a_.first_entry[v] = e;
}

// The factor's record and its share of the pool; the caller writes its values.
template <class Model>
Index FactorGraph<Model>::appendFactor(int kind, Index first, Index second) {
  const Index size = factorValuesOfKind(kind);
  LSLAM_ASSERT(in_update_ && num_factors_ < a_.max_factors &&
               num_factor_values_ + size <= a_.max_factor_values);
  const Index f = num_factors_++;
  a_.factor_kind[f] = static_cast<std::uint8_t>(kind);
  a_.first_variable[f] = first;
  a_.second_variable[f] = second;
  a_.factor_offset[f] = num_factor_values_;
  num_factor_values_ += size;
  link(first, f);
  if (second != kNoIndex) link(second, f);
  return f;
}

// The newest factor was linked last: its entries are the last ones and head its variables' lists.
template <class Model>
void FactorGraph<Model>::takeOutNewestFactor() {
  LSLAM_ASSERT(!in_update_ && num_factors_ > 0);
  const Index f = num_factors_ - 1;
  for (const Index v : {a_.second_variable[f], a_.first_variable[f]}) {
    if (v == kNoIndex) continue;
    const Index e = a_.first_entry[v];
    LSLAM_ASSERT(e == num_entries_ - 1 && a_.entry_factor[e] == f);
    a_.first_entry[v] = a_.next_entry[e];
    --num_entries_;
  }
  num_factor_values_ -= factorValuesOfKind(a_.factor_kind[f]);
  --num_factors_;
  committed_factors_ = num_factors_;
  committed_factor_values_ = num_factor_values_;
  committed_entries_ = num_entries_;
}

template <class Model>
void FactorGraph<Model>::disablePrior(Index f) {
  LSLAM_ASSERT(in_update_ && disabled_ == kNoIndex && f >= 0 && f < committed_factors_ &&
               a_.second_variable[f] == kNoIndex);
  const int kind = a_.factor_kind[f];
  visitKind<Factors>(kind, [&](auto* tag) {
    using F = std::remove_pointer_t<decltype(tag)>;
    constexpr int kSize = F::kErrorDim * F::kErrorDim;
    double* information =
        a_.factor_values + a_.factor_offset[f] + StoredValue<typename F::Measurement>::kSize;
    std::memcpy(disabled_information_, information, sizeof(double) * kSize);
    for (int i = 0; i < kSize; ++i) information[i] = 0.0;
  });
  disabled_ = f;
}

template <class Model>
void FactorGraph<Model>::stage(Index v) {
  if (a_.staged[v] != stamp_) a_.staged_list[staged_count_++] = v;
  a_.staged[v] = stamp_;
}

template <class Model>
void FactorGraph<Model>::relinearizeBy(Index v, const Delta& delta) {
  LSLAM_ASSERT(v >= 0 && v < num_variables_);
  visitKind<Variables>(a_.variable_kind[v], [&](auto* tag) {
    using V = std::remove_pointer_t<decltype(tag)>;
    relinearize<V>(v, linearizationPoint<V>(v).retract(delta.template head<V::kDof>()));
  });
}

template <class Model>
void FactorGraph<Model>::unstageRelinearization() {
  LSLAM_ASSERT(in_update_);
  for (Index i = 0; i < staged_count_; ++i) a_.staged[a_.staged_list[i]] = 0;  // stamps are >= 1
  staged_count_ = 0;
}

template <class Model>
void FactorGraph<Model>::commit() {
  LSLAM_ASSERT(in_update_);
  for (Index i = 0; i < staged_count_; ++i) {
    const Index v = a_.staged_list[i];
    const int size = detail::VariableTables<Variables>::kValueSize[a_.variable_kind[v]];
    std::memcpy(a_.values + a_.value_offset[v], a_.staged_values + a_.value_offset[v],
                sizeof(double) * static_cast<std::size_t>(size));
  }
  committed_variables_ = num_variables_;
  for (int k = 0; k < kMaxVariableKinds; ++k) committed_of_kind_[k] = num_of_kind_[k];
  committed_values_ = num_values_;
  committed_factors_ = num_factors_;
  committed_factor_values_ = num_factor_values_;
  committed_entries_ = num_entries_;
  disabled_ = kNoIndex;
  in_update_ = false;
}

template <class Model>
void FactorGraph<Model>::rollback() {
  LSLAM_ASSERT(in_update_);
  // Unlink the added factors, last first: each was pushed at the head of its variables' lists.
  for (Index f = num_factors_ - 1; f >= committed_factors_; --f) {
    const Index second = a_.second_variable[f];
    if (second != kNoIndex) a_.first_entry[second] = a_.next_entry[a_.first_entry[second]];
    const Index first = a_.first_variable[f];
    a_.first_entry[first] = a_.next_entry[a_.first_entry[first]];
  }
  num_variables_ = committed_variables_;
  for (int k = 0; k < kMaxVariableKinds; ++k) num_of_kind_[k] = committed_of_kind_[k];
  num_values_ = committed_values_;
  num_factors_ = committed_factors_;
  num_factor_values_ = committed_factor_values_;
  num_entries_ = committed_entries_;
  if (disabled_ != kNoIndex) {
    visitKind<Factors>(a_.factor_kind[disabled_], [&](auto* tag) {
      using F = std::remove_pointer_t<decltype(tag)>;
      std::memcpy(a_.factor_values + a_.factor_offset[disabled_] +
                      StoredValue<typename F::Measurement>::kSize,
                  disabled_information_, sizeof(double) * F::kErrorDim * F::kErrorDim);
    });
  }
  disabled_ = kNoIndex;
  staged_count_ = 0;
  in_update_ = false;
}

template <class Model>
double FactorGraph<Model>::factorChi2(Index f) const {
  double result = 0.0;
  visitKind<Factors>(a_.factor_kind[f], [&](auto* tag) {
    using F = std::remove_pointer_t<decltype(tag)>;
    using A = TypeAtT<0, typename F::Variables>;
    const double* values = factorValues(f);
    const auto z = measurementAt<F>(values);
    const A xa = StoredValue<A>::load(valuesOf(a_.first_variable[f], false));
    Matrix<F::kErrorDim, 1> e;
    if constexpr (F::Variables::kSize == 1) {
      e = F::error(xa, z, nullptr);
    } else {
      using B = TypeAtT<1, typename F::Variables>;
      const B xb = StoredValue<B>::load(valuesOf(a_.second_variable[f], false));
      e = F::error(xa, xb, z, nullptr, nullptr);
    }
    const Omega<F> omega = informationAt<F>(values + StoredValue<typename F::Measurement>::kSize);
    result = e.dot(omega * e);
  });
  return result;
}

// Writes the D x kErrorDim block J^T L into the top-left corner of a kMax x kMax one, zero
// elsewhere (the whole block when both are kMax).
template <int D, int E, int kMax, class Jacobian, class Factor>
inline void writeRows(const Jacobian& j, const Factor& l, Eigen::Matrix<double, kMax, kMax>& out) {
  if constexpr (D == kMax && E == kMax) {
    out.noalias() = j.transpose() * l;
  } else {
    out.setZero();
    out.template topLeftCorner<D, E>().noalias() = j.transpose() * l;
  }
}

template <class Model>
Index FactorGraph<Model>::whitenedRows(Index f, const Index* position, Index* positions,
                                       RowBlock* rows_transposed, Delta* rhs) const {
  Index count = 0;
  visitKind<Factors>(a_.factor_kind[f], [&](auto* tag) {
    using F = std::remove_pointer_t<decltype(tag)>;
    using A = TypeAtT<0, typename F::Variables>;
    constexpr int E = F::kErrorDim;
    const double* values = factorValues(f);
    // Omega = L L^T (checked positive definite on input): the rows are L^T J.
    const Omega<F> l = Eigen::LLT<Omega<F>>(informationAt<F>(factorInformation(f))).matrixL();
    const Index first = a_.first_variable[f];
    const A xa = StoredValue<A>::load(valuesOf(first, false));
    Matrix<E, A::kDof> ja;
    Matrix<E, 1> e;
    positions[0] = position[first];
    if constexpr (F::Variables::kSize == 1) {
      e = F::error(xa, measurementAt<F>(values), &ja);
      count = 1;
    } else {
      using B = TypeAtT<1, typename F::Variables>;
      const Index second = a_.second_variable[f];
      const B xb = StoredValue<B>::load(valuesOf(second, false));
      Matrix<E, B::kDof> jb;
      e = F::error(xa, xb, measurementAt<F>(values), &ja, &jb);
      positions[1] = position[second];
      writeRows<B::kDof, E, kMax>(jb, l, rows_transposed[1]);
      count = 2;
    }
    writeRows<A::kDof, E, kMax>(ja, l, rows_transposed[0]);
    if constexpr (E == kMax) {
      rhs->noalias() = -(l.transpose() * e);
    } else {
      rhs->setZero();
      rhs->template head<E>().noalias() = -(l.transpose() * e);
    }
  });
  return count;
}

template <class Model>
double FactorGraph<Model>::chi2() const {
  double sum = 0.0;
  for (Index f = 0; f < num_factors_; ++f) sum += factorChi2(f);
  return sum;
}

template <class Model>
void FactorGraph<Model>::visitNeighbours(Index variable, NeighbourVisitor& visitor) const {
  for (Index e = a_.first_entry[variable]; e != kNoIndex; e = a_.next_entry[e]) {
    const Index other = otherVariable(a_.entry_factor[e], variable);
    if (other != kNoIndex) visitor.visit(other);
  }
}

template <class Model>
void FactorGraph<Model>::addShare(Index f, Index variable, const Index* position, bool committed,
                                  const double* information, double sign, Accumulator& acc,
                                  Later* later) const {
  visitKind<Factors>(a_.factor_kind[f], [&](auto* tag) {
    using F = std::remove_pointer_t<decltype(tag)>;
    using A = TypeAtT<0, typename F::Variables>;
    const double* values = factorValues(f);
    const Index first = a_.first_variable[f];
    const A xa = StoredValue<A>::load(valuesOf(first, committed));
    if constexpr (F::Variables::kSize == 1) {
      Share<F, A::kDof, 1> s;
      linearizeUnary<F>(values, information, xa, s);
      // Negation is exact: subtracting a share is adding its negation, bit for bit.
      acc.addDiagonal(sign * s.aa);
      acc.addEta(sign * s.eta_a);
    } else {
      using B = TypeAtT<1, typename F::Variables>;
      const Index second = a_.second_variable[f];
      const bool is_first = variable == first;
      const Index other = is_first ? second : first;
      const bool other_later = position[other] > position[variable];
      if (later != nullptr && !other_later) return;  // assembled with the earlier column
      const B xb = StoredValue<B>::load(valuesOf(second, committed));
      Share<F, A::kDof, B::kDof> s;
      linearizeBinary<F>(values, information, xa, xb, s);
      if (is_first) {
        acc.addDiagonal(sign * s.aa);
        acc.addEta(sign * s.eta_a);
        if (other_later) acc.addBelow(position[second], sign * s.ba);
        if (later != nullptr) {
          later->addDiagonal(position[second], s.bb);
          later->addEta(position[second], s.eta_b);
        }
      } else {
        acc.addDiagonal(sign * s.bb);
        acc.addEta(sign * s.eta_b);
        if (other_later) acc.addBelow(position[first], sign * s.ba.transpose());
        if (later != nullptr) {
          later->addDiagonal(position[first], s.aa);
          later->addEta(position[first], s.eta_a);
        }
      }
    }
  });
}

template <class Model>
void FactorGraph<Model>::assembleColumn(Index variable, const Index* position, Accumulator& acc,
                                        Later& later) const {
  for (Index e = a_.first_entry[variable]; e != kNoIndex; e = a_.next_entry[e]) {
    const Index f = a_.entry_factor[e];
    addShare(f, variable, position, false, factorInformation(f), 1.0, acc, &later);
  }
}

template <class Model>
void FactorGraph<Model>::assembleColumnChange(Index variable, const Index* position,
                                              Accumulator& acc) const {
  const bool self_moved = isStaged(variable);
  for (Index e = a_.first_entry[variable]; e != kNoIndex; e = a_.next_entry[e]) {
    const Index f = a_.entry_factor[e];
    if (f < committed_factors_) {
      const Index other = otherVariable(f, variable);
      const bool moved = self_moved || (other != kNoIndex && isStaged(other));
      if (!moved && f != disabled_) continue;
      // The old share, with the information it had (a disabled prior's before it was zeroed).
      addShare(f, variable, position, true,
               f == disabled_ ? disabled_information_ : factorInformation(f), -1.0, acc, nullptr);
      if (f == disabled_) continue;  // its current share is zero
    }
    addShare(f, variable, position, false, factorInformation(f), 1.0, acc, nullptr);
  }
}

template <class Model>
const double* FactorGraph<Model>::factorInformation(Index f) const {
  return factorValues(f) + detail::FactorTables<Factors>::kMeasurementSize[a_.factor_kind[f]];
}

template class FactorGraph<Slam2D>;
template class FactorGraph<Slam3D>;
template class FactorGraph<PoseSlam2D>;
template class FactorGraph<PoseSlam3D>;

}  // namespace lslam
