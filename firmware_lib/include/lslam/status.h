#pragma once
#include <cstdint>

namespace lslam {

// Every outcome of a public call. A call that returns anything but Ok has changed no value: the
// one thing a rejected update may have done is the solve layout a full refactorization left
// pending (a storage order, which the next update would have done anyway).
// [[nodiscard]] on the type: no function returning a Status can have it ignored unseen.
// (clang-format 14 takes the attribute for the start of an initializer list.)
// clang-format off
enum class [[nodiscard]] Status : std::uint8_t {
  Ok = 0,
  NonFiniteInput,                  // NaN or Inf in a measurement, information matrix or value
  InformationNotPositiveDefinite,  // information matrix not symmetric positive definite
  UnknownVariable,                 // a factor refers to a variable that does not exist
  DuplicateVariable,               // a variable id that already exists
  UnconstrainedVariable,           // an added variable that no factor of the step constrains
  CapacityExhausted,               // a compile-time capacity (variables, factors, blocks) is full
  WorkspaceExhausted,              // one update needs more than the per-update workspace holds
  NotPositiveDefinite,             // the factorization met a pivot not positive, or not finite
  InvalidArgument,                 // an argument outside its documented range
  NumericalOverflow,               // finite inputs whose weighted error overflows a double
};
// clang-format on

// A short, static, human-readable description ("unknown variable"); never nullptr.
const char* toString(Status status) noexcept;

}  // namespace lslam
