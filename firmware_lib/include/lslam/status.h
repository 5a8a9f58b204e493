#pragma once
#include <cstdint>

namespace lslam {

// Every outcome of a public call. A call that returns anything but Ok has changed nothing.
// [[nodiscard]] on the type: no function returning a Status can have it ignored unseen.
enum class [[nodiscard]] Status : std::uint8_t{
    Ok = 0,
    NonFiniteInput,                  // NaN or Inf in a measurement, information matrix or value
    InformationNotPositiveDefinite,  // information matrix not symmetric positive definite
    UnknownVariable,                 // a factor refers to a variable that does not exist
    DuplicateVariable,               // a variable id that already exists
    UnconstrainedVariable,           // an added variable that no factor of the step constrains
    CapacityExhausted,               // a compile-time capacity (variables, factors, blocks) is full
    WorkspaceExhausted,              // one update needs more than the per-update workspace holds
    NotPositiveDefinite,             // the factorization met a non-positive pivot
    InvalidArgument,                 // an argument outside its documented range
    NumericalOverflow,               // finite inputs whose weighted error overflows a double
};

// A short, static, human-readable description ("unknown variable"); never nullptr.
const char* toString(Status status) noexcept;

}  // namespace lslam
