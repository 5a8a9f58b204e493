#include <doctest/doctest.h>

#include <cstring>

#include "lslam/status.h"

TEST_CASE("every status has its own non-empty description") {
  using lslam::Status;
  const Status all[] = {Status::Ok,
                        Status::NonFiniteInput,
                        Status::InformationNotPositiveDefinite,
                        Status::UnknownVariable,
                        Status::DuplicateVariable,
                        Status::UnconstrainedVariable,
                        Status::CapacityExhausted,
                        Status::WorkspaceExhausted,
                        Status::NotPositiveDefinite,
                        Status::InvalidArgument,
                        Status::NumericalOverflow};
  for (Status a : all) {
    REQUIRE(lslam::toString(a) != nullptr);
    CHECK(std::strlen(lslam::toString(a)) > 0);
    for (Status b : all) {
      if (a != b) CHECK(std::strcmp(lslam::toString(a), lslam::toString(b)) != 0);
    }
  }
}
