#include "lslam/status.h"

namespace lslam {

const char* toString(Status status) noexcept {
  switch (status) {
    case Status::Ok:
      return "ok";
    case Status::NonFiniteInput:
      return "non-finite input (NaN or Inf)";
    case Status::InformationNotPositiveDefinite:
      return "information matrix is not symmetric positive definite";
    case Status::UnknownVariable:
      return "unknown variable id";
    case Status::DuplicateVariable:
      return "duplicate variable id";
    case Status::UnconstrainedVariable:
      return "added variable is not constrained by any factor";
    case Status::CapacityExhausted:
      return "capacity exhausted";
    case Status::WorkspaceExhausted:
      return "update workspace exhausted";
    case Status::NotPositiveDefinite:
      return "factorization is not positive definite";
    case Status::InvalidArgument:
      return "invalid argument";
    case Status::NumericalOverflow:
      return "numerical overflow (information times error beyond the range of a double)";
  }
  return "unknown status";
}

}  // namespace lslam
