#pragma once
// What the caller hands to a model's solver (models/slam_2d.h, slam_3d.h): variables (a kind of
// the model, an id in that kind's id space, an initial value) and measurements (a factor kind, the
// ids of its variables, the measurement and the information), each in an input of fixed size, so
// that one array carries any mix of kinds. Poses and landmarks have separate id spaces: pose 4 and
// landmark 4 are two variables (as in iSAM's files).
//
// Build them with the typed makers; check() is the input check of one input through its kind
// (validateValue, the factor kind's validate), which the solver runs on every input before it
// changes anything.
#include <cstdint>
#include <type_traits>

#include "lslam/assert.h"
#include "lslam/eigen.h"
#include "lslam/graph/factor_graph.h"
#include "lslam/models/model_traits.h"
#include "lslam/solver/id_map.h"
#include "lslam/status.h"
#include "lslam/type_list.h"

namespace lslam {

namespace detail {

template <class List>
struct LargestValue;
template <class... V>
struct LargestValue<TypeList<V...>> {
  static constexpr int kSize = [] {
    int m = 0;
    ((m = StoredValue<V>::kSize > m ? StoredValue<V>::kSize : m), ...);
    return m;
  }();
};

template <class List>
struct LargestFactor;
template <class... F>
struct LargestFactor<TypeList<F...>> {
  static constexpr int kMeasurement = [] {
    int m = 0;
    ((m = StoredValue<typename F::Measurement>::kSize > m
              ? StoredValue<typename F::Measurement>::kSize
              : m),
     ...);
    return m;
  }();
  static constexpr int kErrorDim = [] {
    int m = 0;
    ((m = F::kErrorDim > m ? F::kErrorDim : m), ...);
    return m;
  }();
};

}  // namespace detail

template <class Model>
struct ModelVariableInput {
  static constexpr int kValueSize = detail::LargestValue<typename Model::Variables>::kSize;

  std::uint8_t kind = 0;  // index into Model::Variables
  VariableId id = 0;      // in that kind's id space
  double value[kValueSize] = {};

  template <class V>
  static ModelVariableInput make(VariableId id, const V& initial) noexcept {
    ModelVariableInput in;
    in.kind = static_cast<std::uint8_t>(kVariableKind<Model, V>);
    in.id = id;
    StoredValue<V>::store(initial, in.value);
    return in;
  }
  // The value as kind V (which must be the input's kind).
  template <class V>
  V get() const noexcept {
    LSLAM_ASSERT((kind == kVariableKind<Model, V>));
    return StoredValue<V>::load(value);
  }
  // InvalidArgument for a kind outside the model or a negative id, else validateValue.
  [[nodiscard]] Status check() const noexcept {
    if (id < 0) return Status::InvalidArgument;
    Status status = Status::InvalidArgument;
    visitKind<typename Model::Variables>(kind, [&](auto* tag) {
      using V = std::remove_pointer_t<decltype(tag)>;
      status = validateValue(StoredValue<V>::load(value));
    });
    return status;
  }
};

template <class Model>
struct ModelFactorInput {
  static constexpr int kMeasurementSize =
      detail::LargestFactor<typename Model::Factors>::kMeasurement;
  static constexpr int kMaxErrorDim = detail::LargestFactor<typename Model::Factors>::kErrorDim;

  std::uint8_t kind = 0;       // index into Model::Factors
  VariableId ids[2] = {0, 0};  // its variables' ids, in the order of F::Variables (one for a prior)
  double measurement[kMeasurementSize] = {};
  double information[kMaxErrorDim * kMaxErrorDim] = {};  // kErrorDim^2, column-major

  // A factor on two variables (first, second), or on one (second ignored).
  template <class F>
  static ModelFactorInput make(
      VariableId first, VariableId second, const typename F::Measurement& z,
      const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>& info) noexcept {
    ModelFactorInput in;
    in.kind = static_cast<std::uint8_t>(kFactorKind<Model, F>);
    in.ids[0] = first;
    in.ids[1] = F::Variables::kSize == 2 ? second : first;
    StoredValue<typename F::Measurement>::store(z, in.measurement);
    Eigen::Map<Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>>(in.information) = info;
    return in;
  }
  template <class F>
  static ModelFactorInput make(
      VariableId only, const typename F::Measurement& z,
      const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>& info) noexcept {
    static_assert(F::Variables::kSize == 1, "a factor on one variable");
    return make<F>(only, only, z, info);
  }

  template <class F>
  typename F::Measurement measurementAs() const noexcept {
    LSLAM_ASSERT((kind == kFactorKind<Model, F>));
    return StoredValue<typename F::Measurement>::load(measurement);
  }
  template <class F>
  Eigen::Matrix<double, F::kErrorDim, F::kErrorDim> informationAs() const noexcept {
    LSLAM_ASSERT((kind == kFactorKind<Model, F>));
    return Eigen::Map<const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>>(information);
  }
  // The number of variables of its kind (0 for a kind outside the model).
  int arity() const noexcept {
    int n = 0;
    visitKind<typename Model::Factors>(
        kind, [&](auto* tag) { n = std::remove_pointer_t<decltype(tag)>::Variables::kSize; });
    return n;
  }
  // InvalidArgument for a kind outside the model, a negative id, or a two-variable factor on one
  // variable of one kind (its two ids equal); else the kind's validate(z, information).
  [[nodiscard]] Status check() const noexcept {
    Status status = Status::InvalidArgument;
    visitKind<typename Model::Factors>(kind, [&](auto* tag) {
      using F = std::remove_pointer_t<decltype(tag)>;
      using Vars = typename F::Variables;
      if (ids[0] < 0 || ids[1] < 0) return;
      if constexpr (Vars::kSize == 2) {
        if (std::is_same_v<TypeAtT<0, Vars>, TypeAtT<1, Vars>> && ids[0] == ids[1]) return;
      }
      status = F::validate(measurementAs<F>(), informationAs<F>());
    });
    return status;
  }
};

}  // namespace lslam
