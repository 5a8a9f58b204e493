#include "host_sim/model_chi2.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "model_geometry.h"

namespace lslam::sim {

namespace {

using namespace geometry;

// A 2D rigid transform.
struct Rigid2 {
  Eigen::Matrix2d r;
  Eigen::Vector2d t;
};

// (t, qvec with qw >= 0) of the transform (q, t).
Vector6d g2oVector(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
  Vector6d e;
  e.head<3>() = t;
  const double sign = q.w() < 0.0 ? -1.0 : 1.0;
  e.tail<3>() = sign * q.vec();
  return e;
}

// (x, y, z, yaw, pitch, roll) of the transform (q, t), iSAM's Pose3d::vector().
Vector6d isamVector(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
  Vector6d v;
  v.head<3>() = t;
  v.tail<3>() = isamYawPitchRoll(q);
  return v;
}

Vector6d wrapTail(Vector6d e) {
  for (int k = 3; k < 6; ++k) e(k) = wrapAngle(e(k));
  return e;
}

// Relative transform Xi^-1 Xj of SE3 parameter arrays.
void relativeSE3(const double* xi, const double* xj, Eigen::Quaterniond* q, Eigen::Vector3d* t) {
  const Eigen::Quaterniond qi = quat(xi);
  const Eigen::Quaterniond qj = quat(xj);
  const Eigen::Vector3d ti(xi[0], xi[1], xi[2]);
  const Eigen::Vector3d tj(xj[0], xj[1], xj[2]);
  *q = qi.conjugate() * qj;
  *t = qi.conjugate() * (tj - ti);
}

// Z^-1 (q, t).
void leftInverse(const double* z, Eigen::Quaterniond* q, Eigen::Vector3d* t) {
  const Eigen::Quaterniond qz = quat(z);
  const Eigen::Vector3d tz(z[0], z[1], z[2]);
  *t = qz.conjugate() * (*t - tz);
  *q = qz.conjugate() * *q;
}

void betweenSE2G2o(const double* xi, const double* xj, const double* z, double* e) {
  const Eigen::Matrix2d ri = rot2(xi[2]);
  const Eigen::Vector2d rel = ri.transpose() * Eigen::Vector2d(xj[0] - xi[0], xj[1] - xi[1]);
  const Eigen::Vector2d exy = rot2(z[2]).transpose() * (rel - Eigen::Vector2d(z[0], z[1]));
  e[0] = exy.x();
  e[1] = exy.y();
  e[2] = wrapAngle(xj[2] - xi[2] - z[2]);
}

void betweenSE2Isam(const double* xi, const double* xj, const double* z, double* e) {
  const Eigen::Vector2d rel =
      rot2(xi[2]).transpose() * Eigen::Vector2d(xj[0] - xi[0], xj[1] - xi[1]);
  e[0] = rel.x() - z[0];
  e[1] = rel.y() - z[1];
  e[2] = wrapAngle(wrapAngle(xj[2] - xi[2]) - z[2]);
}

void pointXY2(const double* x, const double* l, const double* z, double* e) {
  const Eigen::Vector2d d = rot2(x[2]).transpose() * Eigen::Vector2d(l[0] - x[0], l[1] - x[1]);
  e[0] = d.x() - z[0];
  e[1] = d.y() - z[1];
}

void rangeBearing2(const double* x, const double* l, const double* z, double* e) {
  const Eigen::Vector2d d = rot2(x[2]).transpose() * Eigen::Vector2d(l[0] - x[0], l[1] - x[1]);
  e[0] = d.norm() - z[0];
  e[1] = wrapAngle(std::atan2(d.y(), d.x()) - z[1]);
}

void pointXYZ3(const double* x, const double* l, const double* z, double* e) {
  const Eigen::Vector3d d =
      quat(x).conjugate() * Eigen::Vector3d(l[0] - x[0], l[1] - x[1], l[2] - x[2]);
  for (int k = 0; k < 3; ++k) e[k] = d(k) - z[k];
}

void betweenSE3G2o(const double* xi, const double* xj, const double* z, double* e) {
  Eigen::Quaterniond q;
  Eigen::Vector3d t;
  relativeSE3(xi, xj, &q, &t);
  leftInverse(z, &q, &t);
  Eigen::Map<Vector6d> out(e);
  out = g2oVector(q, t);
}

void priorSE3G2o(const double* x, const double* z, double* e) {
  Eigen::Quaterniond q = quat(x);
  Eigen::Vector3d t(x[0], x[1], x[2]);
  leftInverse(z, &q, &t);
  Eigen::Map<Vector6d> out(e);
  out = g2oVector(q, t);
}

void betweenSE3Isam(const double* xi, const double* xj, const double* z, double* e) {
  Eigen::Quaterniond q;
  Eigen::Vector3d t;
  relativeSE3(xi, xj, &q, &t);
  const Vector6d vz = isamVector(quat(z), Eigen::Vector3d(z[0], z[1], z[2]));
  Eigen::Map<Vector6d> out(e);
  out = wrapTail(isamVector(q, t) - vz);
}

void priorSE3Isam(const double* x, const double* z, double* e) {
  const Vector6d vx = isamVector(quat(x), Eigen::Vector3d(x[0], x[1], x[2]));
  const Vector6d vz = isamVector(quat(z), Eigen::Vector3d(z[0], z[1], z[2]));
  Eigen::Map<Vector6d> out(e);
  out = wrapTail(vx - vz);
}

const Eigen::VectorXd& lookup(const ModelEstimate& values, const VariableKey& key,
                              const ModelFactor& f) {
  const auto it = values.find(key);
  if (it == values.end()) {
    throw std::invalid_argument(std::string("model chi2: ") +
                                (key.role == VariableRole::Pose ? "pose " : "landmark ") +
                                std::to_string(key.id) + " of " + factorKindName(f.kind) +
                                " (line " + std::to_string(f.line) + ") has no value");
  }
  return it->second;
}

Eigen::VectorXd identity(VariableKind kind) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(parameterCount(kind));
  if (kind == VariableKind::SE3) v[6] = 1.0;
  return v;
}

}  // namespace

Eigen::Vector3d errorBetweenSE2G2o(const Eigen::Vector3d& xi, const Eigen::Vector3d& xj,
                                   const Eigen::Vector3d& z) {
  Eigen::Vector3d e;
  betweenSE2G2o(xi.data(), xj.data(), z.data(), e.data());
  return e;
}

Eigen::Vector3d errorPriorSE2G2o(const Eigen::Vector3d& x, const Eigen::Vector3d& z) {
  return errorBetweenSE2G2o(Eigen::Vector3d::Zero(), x, z);
}

Vector6d errorBetweenSE3G2o(const Vector7d& xi, const Vector7d& xj, const Vector7d& z) {
  Vector6d e;
  betweenSE3G2o(xi.data(), xj.data(), z.data(), e.data());
  return e;
}

Vector6d errorPriorSE3G2o(const Vector7d& x, const Vector7d& z) {
  Vector6d e;
  priorSE3G2o(x.data(), z.data(), e.data());
  return e;
}

Eigen::Vector3d errorBetweenSE2Isam(const Eigen::Vector3d& xi, const Eigen::Vector3d& xj,
                                    const Eigen::Vector3d& z) {
  Eigen::Vector3d e;
  betweenSE2Isam(xi.data(), xj.data(), z.data(), e.data());
  return e;
}

Eigen::Vector3d errorPriorSE2Isam(const Eigen::Vector3d& x, const Eigen::Vector3d& z) {
  return Eigen::Vector3d(x[0] - z[0], x[1] - z[1], wrapAngle(x[2] - z[2]));
}

Vector6d errorBetweenSE3Isam(const Vector7d& xi, const Vector7d& xj, const Vector7d& z) {
  Vector6d e;
  betweenSE3Isam(xi.data(), xj.data(), z.data(), e.data());
  return e;
}

Vector6d errorPriorSE3Isam(const Vector7d& x, const Vector7d& z) {
  Vector6d e;
  priorSE3Isam(x.data(), z.data(), e.data());
  return e;
}

Eigen::Vector2d errorPointXY2(const Eigen::Vector3d& x, const Eigen::Vector2d& l,
                              const Eigen::Vector2d& z) {
  Eigen::Vector2d e;
  pointXY2(x.data(), l.data(), z.data(), e.data());
  return e;
}

Eigen::Vector2d errorRangeBearing2(const Eigen::Vector3d& x, const Eigen::Vector2d& l,
                                   const Eigen::Vector2d& z) {
  Eigen::Vector2d e;
  rangeBearing2(x.data(), l.data(), z.data(), e.data());
  return e;
}

Eigen::Vector3d errorPointXYZ3(const Vector7d& x, const Eigen::Vector3d& l,
                               const Eigen::Vector3d& z) {
  Eigen::Vector3d e;
  pointXYZ3(x.data(), l.data(), z.data(), e.data());
  return e;
}

Eigen::Vector3d isamYawPitchRoll(const Eigen::Quaterniond& q_in) {
  const Eigen::Quaterniond q = q_in.normalized();
  const double w = q.w();
  const double x = q.x();
  const double y = q.y();
  const double z = q.z();
  const double yaw = std::atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z);
  const double pitch = std::asin(std::clamp(2.0 * (w * y - z * x), -1.0, 1.0));
  const double roll = std::atan2(2.0 * (w * x + y * z), w * w - x * x - y * y + z * z);
  return Eigen::Vector3d(yaw, pitch, roll);
}

void factorErrorRaw(ObjectiveConvention convention, FactorKind kind, const double* first,
                    const double* second, const double* z, double* e) {
  const bool isam = convention == ObjectiveConvention::Isam;
  switch (kind) {
    case FactorKind::PriorSE2:
      if (isam) {
        e[0] = first[0] - z[0];
        e[1] = first[1] - z[1];
        e[2] = wrapAngle(first[2] - z[2]);
      } else {
        const double origin[3] = {0.0, 0.0, 0.0};
        betweenSE2G2o(origin, first, z, e);
      }
      return;
    case FactorKind::BetweenSE2:
      if (isam) {
        betweenSE2Isam(first, second, z, e);
      } else {
        betweenSE2G2o(first, second, z, e);
      }
      return;
    case FactorKind::PriorPoint2:
      e[0] = first[0] - z[0];
      e[1] = first[1] - z[1];
      return;
    case FactorKind::PointXY2:
      pointXY2(first, second, z, e);
      return;
    case FactorKind::RangeBearing2:
      rangeBearing2(first, second, z, e);
      return;
    case FactorKind::PriorSE3:
      if (isam) {
        priorSE3Isam(first, z, e);
      } else {
        priorSE3G2o(first, z, e);
      }
      return;
    case FactorKind::BetweenSE3:
      if (isam) {
        betweenSE3Isam(first, second, z, e);
      } else {
        betweenSE3G2o(first, second, z, e);
      }
      return;
    case FactorKind::PriorPoint3:
      for (int k = 0; k < 3; ++k) e[k] = first[k] - z[k];
      return;
    case FactorKind::PointXYZ3:
      pointXYZ3(first, second, z, e);
      return;
  }
}

VariableKind factorVariableKind(FactorKind kind, int slot) {
  switch (kind) {
    case FactorKind::PriorSE2:
    case FactorKind::BetweenSE2:
      return VariableKind::SE2;
    case FactorKind::PriorPoint2:
      return VariableKind::Point2;
    case FactorKind::PointXY2:
    case FactorKind::RangeBearing2:
      return slot == 0 ? VariableKind::SE2 : VariableKind::Point2;
    case FactorKind::PriorSE3:
    case FactorKind::BetweenSE3:
      return VariableKind::SE3;
    case FactorKind::PriorPoint3:
      return VariableKind::Point3;
    case FactorKind::PointXYZ3:
      return slot == 0 ? VariableKind::SE3 : VariableKind::Point3;
  }
  throw std::invalid_argument("factorVariableKind: unknown factor kind");
}

int measurementSize(FactorKind kind) {
  switch (kind) {
    case FactorKind::PriorSE2:
    case FactorKind::BetweenSE2:
      return 3;
    case FactorKind::PriorSE3:
    case FactorKind::BetweenSE3:
      return 7;
    case FactorKind::RangeBearing2:
      return 2;
    default:
      return parameterCount(factorVariableKind(kind, arity(kind) - 1));
  }
}

bool isAngularErrorComponent(ObjectiveConvention convention, FactorKind kind, int k) {
  switch (kind) {
    case FactorKind::PriorSE2:
    case FactorKind::BetweenSE2:
      return k == 2;
    case FactorKind::RangeBearing2:
      return k == 1;
    case FactorKind::PriorSE3:
    case FactorKind::BetweenSE3:
      return convention == ObjectiveConvention::Isam && k >= 3;
    default:
      return false;
  }
}

Eigen::VectorXd factorError(ObjectiveConvention convention, const ModelFactor& f,
                            const Eigen::VectorXd& first, const Eigen::VectorXd& second) {
  const auto bad = [&](const std::string& what) {
    return std::invalid_argument(std::string("factorError: ") + factorKindName(f.kind) + " (line " +
                                 std::to_string(f.line) + "): " + what);
  };
  if (f.measurement.size() != measurementSize(f.kind)) throw bad("measurement size");
  if (first.size() != parameterCount(factorVariableKind(f.kind, 0))) {
    throw bad("first value size");
  }
  const bool two = arity(f.kind) == 2;
  if (two && second.size() != parameterCount(factorVariableKind(f.kind, 1))) {
    throw bad("second value size");
  }
  Eigen::VectorXd e(errorDimension(f.kind));
  factorErrorRaw(convention, f.kind, first.data(), two ? second.data() : nullptr,
                 f.measurement.data(), e.data());
  return e;
}

Eigen::VectorXd factorError(ObjectiveConvention convention, const ModelFactor& f,
                            const ModelEstimate& values) {
  const Eigen::VectorXd& a = lookup(values, f.first, f);
  if (arity(f.kind) == 1) return factorError(convention, f, a, Eigen::VectorXd());
  return factorError(convention, f, a, lookup(values, f.second, f));
}

double chi2(const ModelDataset& d, const ModelEstimate& values) {
  double sum = 0.0;
  for (const ModelFactor& f : d.factors) {
    const Eigen::VectorXd e = factorError(d.convention, f, values);
    sum += e.dot(f.information * e);
  }
  return sum;
}

std::unordered_map<VariableKey, VariableKind, VariableKeyHash> variableKinds(
    const ModelDataset& d) {
  std::unordered_map<VariableKey, VariableKind, VariableKeyHash> kinds;
  const auto note = [&](const VariableKey& key, VariableKind kind, std::size_t line) {
    const auto [it, inserted] = kinds.emplace(key, kind);
    if (!inserted && it->second != kind) {
      throw std::invalid_argument("variableKinds: variable " + std::to_string(key.id) +
                                  " is used as " + variableKindName(it->second) + " and as " +
                                  variableKindName(kind) + " (line " + std::to_string(line) + ")");
    }
  };
  for (const ModelVertex& v : d.vertices) note(v.key, v.kind, v.line);
  for (const ModelFactor& f : d.factors) {
    note(f.first, factorVariableKind(f.kind, 0), f.line);
    if (arity(f.kind) == 2) note(f.second, factorVariableKind(f.kind, 1), f.line);
  }
  return kinds;
}

ModelEstimate initialEstimate(const ModelDataset& d) {
  const auto kinds = variableKinds(d);
  ModelEstimate est;
  for (const ModelVertex& v : d.vertices) est[v.key] = v.value;
  const auto known = [&](const VariableKey& k) { return est.count(k) != 0; };
  for (const ModelFactor& f : d.factors) {
    const Eigen::VectorXd& z = f.measurement;
    if (z.size() != measurementSize(f.kind)) {
      throw std::invalid_argument(std::string("initialEstimate: ") + factorKindName(f.kind) +
                                  " (line " + std::to_string(f.line) + "): measurement size");
    }
    if (arity(f.kind) == 1) {
      if (!known(f.first)) est[f.first] = z;
      continue;
    }
    const bool two_poses = f.kind == FactorKind::BetweenSE2 || f.kind == FactorKind::BetweenSE3;
    const bool se3 = factorVariableKind(f.kind, 0) == VariableKind::SE3;
    if (known(f.first) && known(f.second)) continue;
    if (!known(f.first) && !known(f.second)) {
      est[f.first] = identity(kinds.at(f.first));  // a new component: its first pose at the origin
    }
    if (two_poses) {
      if (!known(f.second)) {
        est[f.second] = se3 ? composeSE3(est.at(f.first), z) : composeSE2(est.at(f.first), z);
      } else {
        est[f.first] = se3 ? composeSE3(est.at(f.second), inverseSE3(z))
                           : composeSE2(est.at(f.second), inverseSE2(z));
      }
      continue;
    }
    // An observation: the position of the landmark in the pose's frame.
    Eigen::VectorXd local = z;
    if (f.kind == FactorKind::RangeBearing2) {
      local = Eigen::Vector2d(z[0] * std::cos(z[1]), z[0] * std::sin(z[1]));
    }
    if (!known(f.second)) {
      const Eigen::VectorXd& x = est.at(f.first);
      if (se3) {
        est[f.second] = x.head<3>() + quat(x.data()) * local.head<3>();
      } else {
        est[f.second] = x.head<2>() + rot2(x[2]) * local.head<2>();
      }
    } else {
      const Eigen::VectorXd& l = est.at(f.second);
      Eigen::VectorXd x = identity(kinds.at(f.first));
      x.head(l.size()) = l - local;
      est[f.first] = x;
    }
  }
  return est;
}

}  // namespace lslam::sim
