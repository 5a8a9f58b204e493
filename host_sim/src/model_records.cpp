#include "model_records.h"

#include <cmath>

#include "lslam/factors/information.h"
#include "record_parsing.h"

namespace lslam::sim::records {

namespace {

// The double nearest pi (below it): |bearing| <= kPi is exactly bearing in (-pi, pi].
constexpr double kPi = 3.141592653589793;

}  // namespace

const char* vertexTag(VariableKind kind, DatasetFormat format) {
  switch (kind) {
    case VariableKind::SE2:
      return format == DatasetFormat::Toro ? "VERTEX2" : "VERTEX_SE2";
    case VariableKind::Point2:
      return "VERTEX_XY";
    case VariableKind::SE3:
      return "VERTEX_SE3:QUAT";
    case VariableKind::Point3:
      return "VERTEX_TRACKXYZ";
  }
  return "VERTEX";
}

const char* factorTag(FactorKind kind, DatasetFormat format) {
  switch (kind) {
    case FactorKind::BetweenSE2:
      return format == DatasetFormat::Toro ? "EDGE2" : "EDGE_SE2";
    case FactorKind::PointXY2:
      return "EDGE_SE2_XY";
    case FactorKind::RangeBearing2:
      return "EDGE_SE2_RANGE_BEARING";
    case FactorKind::BetweenSE3:
      return "EDGE_SE3:QUAT";
    case FactorKind::PointXYZ3:
      return "EDGE_SE3_TRACKXYZ";
    default:
      return factorKindName(kind);
  }
}

bool isPositiveDefinite(const Eigen::MatrixXd& m) {
  switch (m.rows()) {
    case 2:
      return lslam::checkInformation(Eigen::Matrix2d(m)) == lslam::Status::Ok;
    case 3:
      return lslam::checkInformation(Eigen::Matrix3d(m)) == lslam::Status::Ok;
    case 6:
      return lslam::checkInformation(Eigen::Matrix<double, 6, 6>(m)) == lslam::Status::Ok;
    default:
      return false;
  }
}

std::string rangeBearingProblem(double range, double bearing) {
  if (!(range > 0.0)) return "range " + parsing::formatDouble(range) + " is not positive";
  if (!(std::abs(bearing) <= kPi)) {
    return "bearing " + parsing::formatDouble(bearing) + " is outside (-pi, pi] (radians, wrapped)";
  }
  return {};
}

}  // namespace lslam::sim::records
