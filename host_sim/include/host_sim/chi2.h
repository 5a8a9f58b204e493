#pragma once
// The g2o chi2 of a 2D pose graph: the objective the batch reference solver minimises and the
// number every solver in the project is compared on. Host-only, independent of firmware_lib (it
// includes no lslam/ header and shares no geometry code with it).
#include <Eigen/Core>
#include <cstdint>
#include <unordered_map>

#include "host_sim/dataset.h"

namespace lslam::sim {

// A value for every pose, keyed by pose id.
using Estimate2D = std::unordered_map<std::int64_t, Pose2D>;

// theta wrapped to (-pi, pi].
double wrapAngle(double theta);

// The g2o SE2 edge error: e = (x, y, theta) of Z^-1 * Xi^-1 * Xj, theta wrapped to (-pi, pi].
// Written out: e_xy = R(z.theta)^T (R(xi.theta)^T (tj - ti) - tz), e_th = wrap(thj - thi - thz).
Eigen::Vector3d edgeErrorG2o(const Pose2D& xi, const Pose2D& xj, const Pose2D& z);

// chi2 = sum over d.edges of e^T * Omega * e (e from edgeErrorG2o, Omega = edge.information as
// stored, used exactly as given). Throws std::invalid_argument if an edge references a pose that is
// not in `poses`.
double chi2G2o(const Dataset2D& d, const Estimate2D& poses);

// Estimate2D from the dataset's vertices (a later vertex line with the same id wins).
Estimate2D estimateFromVertices(const Dataset2D& d);

}  // namespace lslam::sim
