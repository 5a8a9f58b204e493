#include "host_sim/chi2.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace lslam::sim {

namespace {
constexpr double kPi = 3.14159265358979323846;

const Pose2D& lookup(const Estimate2D& poses, std::int64_t id, const Edge2D& e) {
  const auto it = poses.find(id);
  if (it == poses.end()) {
    throw std::invalid_argument("chi2G2o: pose " + std::to_string(id) + " used by edge " +
                                std::to_string(e.from) + "->" + std::to_string(e.to) + " (line " +
                                std::to_string(e.line) + ") has no value");
  }
  return it->second;
}
}  // namespace

double wrapAngle(double theta) {
  // std::remainder gives [-pi, pi] (pi as the double nearest to it); move -pi to +pi.
  double r = std::remainder(theta, 2.0 * kPi);
  if (r <= -kPi) r += 2.0 * kPi;
  return r;
}

Eigen::Vector3d edgeErrorG2o(const Pose2D& xi, const Pose2D& xj, const Pose2D& z) {
  // Relative pose Xi^-1 * Xj.
  const double ci = std::cos(xi.theta);
  const double si = std::sin(xi.theta);
  const double dx = xj.x - xi.x;
  const double dy = xj.y - xi.y;
  const double rx = ci * dx + si * dy;
  const double ry = -si * dx + ci * dy;
  // Z^-1 * (Xi^-1 * Xj).
  const double cz = std::cos(z.theta);
  const double sz = std::sin(z.theta);
  const double ux = rx - z.x;
  const double uy = ry - z.y;
  return Eigen::Vector3d(cz * ux + sz * uy, -sz * ux + cz * uy,
                         wrapAngle(xj.theta - xi.theta - z.theta));
}

double chi2G2o(const Dataset2D& d, const Estimate2D& poses) {
  double sum = 0.0;
  for (const Edge2D& e : d.edges) {
    const Eigen::Vector3d r =
        edgeErrorG2o(lookup(poses, e.from, e), lookup(poses, e.to, e), e.measurement);
    sum += r.dot(e.information * r);
  }
  return sum;
}

Estimate2D estimateFromVertices(const Dataset2D& d) {
  Estimate2D out;
  out.reserve(d.vertices.size());
  for (const Vertex2D& v : d.vertices) out[v.id] = v.pose;
  return out;
}

}  // namespace lslam::sim
