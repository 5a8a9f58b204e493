#include "host_sim/model_dataset.h"

#include <cstdlib>

namespace lslam::sim {

int tangentDimension(VariableKind kind) {
  switch (kind) {
    case VariableKind::SE2:
      return 3;
    case VariableKind::Point2:
      return 2;
    case VariableKind::SE3:
      return 6;
    case VariableKind::Point3:
      return 3;
  }
  std::abort();
}

int parameterCount(VariableKind kind) {
  return kind == VariableKind::SE3 ? 7 : tangentDimension(kind);
}

const char* variableKindName(VariableKind kind) {
  switch (kind) {
    case VariableKind::SE2:
      return "SE2";
    case VariableKind::Point2:
      return "Point2";
    case VariableKind::SE3:
      return "SE3";
    case VariableKind::Point3:
      return "Point3";
  }
  std::abort();
}

const char* factorKindName(FactorKind kind) {
  switch (kind) {
    case FactorKind::PriorSE2:
      return "PriorSE2";
    case FactorKind::BetweenSE2:
      return "BetweenSE2";
    case FactorKind::PriorPoint2:
      return "PriorPoint2";
    case FactorKind::PointXY2:
      return "PointXY2";
    case FactorKind::RangeBearing2:
      return "RangeBearing2";
    case FactorKind::PriorSE3:
      return "PriorSE3";
    case FactorKind::BetweenSE3:
      return "BetweenSE3";
    case FactorKind::PriorPoint3:
      return "PriorPoint3";
    case FactorKind::PointXYZ3:
      return "PointXYZ3";
  }
  std::abort();
}

int errorDimension(FactorKind kind) {
  switch (kind) {
    case FactorKind::PriorSE2:
    case FactorKind::BetweenSE2:
      return 3;
    case FactorKind::PriorPoint2:
    case FactorKind::PointXY2:
    case FactorKind::RangeBearing2:
      return 2;
    case FactorKind::PriorSE3:
    case FactorKind::BetweenSE3:
      return 6;
    case FactorKind::PriorPoint3:
    case FactorKind::PointXYZ3:
      return 3;
  }
  std::abort();
}

int arity(FactorKind kind) {
  switch (kind) {
    case FactorKind::PriorSE2:
    case FactorKind::PriorPoint2:
    case FactorKind::PriorSE3:
    case FactorKind::PriorPoint3:
      return 1;
    default:
      return 2;
  }
}

VariableRole roleOf(VariableKind kind) {
  return kind == VariableKind::SE2 || kind == VariableKind::SE3 ? VariableRole::Pose
                                                                : VariableRole::Landmark;
}

const char* roleName(VariableRole role) {
  return role == VariableRole::Pose ? "pose" : "landmark";
}

int dimensionOf(VariableKind kind) {
  return kind == VariableKind::SE2 || kind == VariableKind::Point2 ? 2 : 3;
}

std::pair<VariableKind, VariableKind> endpointKinds(FactorKind kind) {
  switch (kind) {
    case FactorKind::PriorSE2:
    case FactorKind::BetweenSE2:
      return {VariableKind::SE2, VariableKind::SE2};
    case FactorKind::PriorPoint2:
      return {VariableKind::Point2, VariableKind::Point2};
    case FactorKind::PointXY2:
    case FactorKind::RangeBearing2:
      return {VariableKind::SE2, VariableKind::Point2};
    case FactorKind::PriorSE3:
    case FactorKind::BetweenSE3:
      return {VariableKind::SE3, VariableKind::SE3};
    case FactorKind::PriorPoint3:
      return {VariableKind::Point3, VariableKind::Point3};
    case FactorKind::PointXYZ3:
      return {VariableKind::SE3, VariableKind::Point3};
  }
  std::abort();
}

VariableKind kindOfRole(VariableRole role, int dimension) {
  if (role == VariableRole::Pose) return dimension == 2 ? VariableKind::SE2 : VariableKind::SE3;
  return dimension == 2 ? VariableKind::Point2 : VariableKind::Point3;
}

}  // namespace lslam::sim
