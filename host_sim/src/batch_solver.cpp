#include "host_sim/batch_solver.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "batch_common.h"

namespace lslam::sim {

Pose2D retract2D(const Pose2D& x, const Eigen::Vector3d& delta) {
  const double c = std::cos(x.theta);
  const double s = std::sin(x.theta);
  Pose2D out;
  out.x = x.x + c * delta.x() - s * delta.y();
  out.y = x.y + s * delta.x() + c * delta.y();
  out.theta = wrapAngle(x.theta + delta.z());
  return out;
}

void edgeJacobiansG2o(const Pose2D& xi, const Pose2D& xj, const Pose2D& z, Eigen::Matrix3d* jac_i,
                      Eigen::Matrix3d* jac_j) {
  // e_xy = Rz^T (Ri^T (tj - ti) - tz), e_th = thj - thi - thz.
  // d e_xy / d(di_xy) = -Rz^T          d e_xy / d(di_th) = -Rz^T S Ri^T (tj - ti), S = [0 -1; 1 0]
  // d e_xy / d(dj_xy) = R(thj-thi-thz) d e_th / d(di_th) = -1, d e_th / d(dj_th) = +1.
  const double ci = std::cos(xi.theta);
  const double si = std::sin(xi.theta);
  const double dx = xj.x - xi.x;
  const double dy = xj.y - xi.y;
  const double rx = ci * dx + si * dy;  // Ri^T (tj - ti)
  const double ry = -si * dx + ci * dy;
  const double cz = std::cos(z.theta);
  const double sz = std::sin(z.theta);
  // S * r = (-ry, rx); Rz^T * v = (cz vx + sz vy, -sz vx + cz vy).
  const double srx = -ry;
  const double sry = rx;
  if (jac_i != nullptr) {
    Eigen::Matrix3d& a = *jac_i;
    a << -cz, -sz, -(cz * srx + sz * sry),  //
        sz, -cz, -(-sz * srx + cz * sry),   //
        0.0, 0.0, -1.0;
  }
  if (jac_j != nullptr) {
    const double phi = xj.theta - xi.theta - z.theta;
    const double c = std::cos(phi);
    const double s = std::sin(phi);
    Eigen::Matrix3d& b = *jac_j;
    b << c, -s, 0.0,  //
        s, c, 0.0,    //
        0.0, 0.0, 1.0;
  }
}

namespace {

using batch_detail::BlockPattern;
using batch_detail::SpMat;

// One edge as the solver sees it. Variable positions are after the COLAMD permutation; -1 = fixed.
struct Term {
  const Edge2D* edge = nullptr;
  int vi = -1;
  int vj = -1;
  Eigen::Matrix3d whiten;  // R with Omega = R^T R
  int off_block = -1;      // block (max(vi,vj), min(vi,vj)) in the pattern, -1 if none
};

class Problem {
 public:
  Problem(const Dataset2D& d, const Estimate2D& initial, const BatchOptions& options);

  int numVariables() const { return static_cast<int>(var_ids_.size()); }
  // Whitened chi2 at `x` (vector of variable poses in position order).
  double chi2(const std::vector<Pose2D>& x) const;
  // Fills H (values only; the pattern is fixed) and g = J^T r; returns chi2 at x.
  double linearize(const std::vector<Pose2D>& x, SpMat* h, Eigen::VectorXd* g) const;
  std::vector<Pose2D> applyStep(const std::vector<Pose2D>& x, const Eigen::VectorXd& dx) const;
  const SpMat& pattern() const { return blocks_.pattern(); }
  const std::vector<int>& diagOffsets() const { return blocks_.diagOffsets(); }
  std::vector<Pose2D> variables(const Estimate2D& est) const;
  void store(const std::vector<Pose2D>& x, Estimate2D* est) const;

 private:
  const Pose2D& pose(const std::vector<Pose2D>& x, int v, std::int64_t id) const {
    return v >= 0 ? x[static_cast<std::size_t>(v)] : fixed_pose_.at(id);
  }
  std::vector<std::int64_t> var_ids_;  // position -> id
  std::unordered_map<std::int64_t, Pose2D> fixed_pose_;
  std::vector<Term> terms_;
  BlockPattern blocks_{std::vector<int>{}};
};

Problem::Problem(const Dataset2D& d, const Estimate2D& initial, const BatchOptions& options) {
  // Fixed set (the gauge).
  std::unordered_set<std::int64_t> fixed(options.fixed.begin(), options.fixed.end());
  if (fixed.empty()) {
    for (const FixedPose& f : d.fixed) fixed.insert(f.id);
  }
  if (fixed.empty() && !d.edges.empty()) {
    std::int64_t smallest = std::numeric_limits<std::int64_t>::max();
    for (const Edge2D& e : d.edges) smallest = std::min({smallest, e.from, e.to});
    fixed.insert(smallest);
  }

  // Variables: every id referenced by an edge and not fixed; sorted by id before ordering.
  std::vector<std::int64_t> ids;
  {
    std::unordered_set<std::int64_t> seen;
    for (const Edge2D& e : d.edges) {
      for (const std::int64_t id : {e.from, e.to}) {
        if (!seen.insert(id).second) continue;
        const auto it = initial.find(id);
        if (it == initial.end()) {
          throw std::invalid_argument("solveBatch2D: pose " + std::to_string(id) + " (edge line " +
                                      std::to_string(e.line) + ") has no initial value");
        }
        if (fixed.count(id) != 0) {
          fixed_pose_[id] = it->second;
        } else {
          ids.push_back(id);
        }
      }
    }
  }
  std::sort(ids.begin(), ids.end());
  std::unordered_map<std::int64_t, int> index;  // id -> index in `ids`
  for (std::size_t k = 0; k < ids.size(); ++k) index[ids[k]] = static_cast<int>(k);
  const auto indexOf = [&](std::int64_t id) {
    const auto it = index.find(id);
    return it == index.end() ? -1 : it->second;
  };
  const int n = static_cast<int>(ids.size());

  // COLAMD on the block structure of A: one row per edge with a variable, one column per variable.
  std::vector<std::vector<int>> col_rows(static_cast<std::size_t>(n));
  int n_row = 0;
  for (const Edge2D& e : d.edges) {
    const int a = indexOf(e.from);
    const int b = indexOf(e.to);
    if (a < 0 && b < 0) continue;
    if (a >= 0) col_rows[static_cast<std::size_t>(a)].push_back(n_row);
    if (b >= 0 && b != a) col_rows[static_cast<std::size_t>(b)].push_back(n_row);
    ++n_row;
  }
  // position -> index in ids
  const std::vector<int> perm = batch_detail::colamdOrdering(n_row, col_rows, "solveBatch2D");
  std::vector<int> pos(static_cast<std::size_t>(n));  // index in ids -> position
  var_ids_.resize(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    pos[static_cast<std::size_t>(perm[static_cast<std::size_t>(k)])] = k;
    var_ids_[static_cast<std::size_t>(k)] =
        ids[static_cast<std::size_t>(perm[static_cast<std::size_t>(k)])];
  }

  // Terms and the block pattern of the lower triangle of H.
  blocks_ = BlockPattern(std::vector<int>(static_cast<std::size_t>(n), 3));
  terms_.reserve(d.edges.size());
  for (const Edge2D& e : d.edges) {
    Term t;
    t.edge = &e;
    const int a = indexOf(e.from);
    const int b = indexOf(e.to);
    t.vi = a >= 0 ? pos[static_cast<std::size_t>(a)] : -1;
    t.vj = b >= 0 ? pos[static_cast<std::size_t>(b)] : -1;
    const Eigen::Matrix3d omega = 0.5 * (e.information + e.information.transpose());
    Eigen::LLT<Eigen::Matrix3d> llt(omega);
    if (llt.info() != Eigen::Success || !omega.allFinite()) {
      throw std::invalid_argument("solveBatch2D: information matrix of edge " +
                                  std::to_string(e.from) + "->" + std::to_string(e.to) + " (line " +
                                  std::to_string(e.line) + ") is not positive definite");
    }
    t.whiten = llt.matrixU();  // Omega = U^T U
    if (t.vi >= 0 && t.vj >= 0 && t.vi != t.vj) t.off_block = blocks_.offDiagonal(t.vi, t.vj);
    terms_.push_back(t);
  }
  blocks_.finalize();
}

std::vector<Pose2D> Problem::variables(const Estimate2D& est) const {
  std::vector<Pose2D> x;
  x.reserve(var_ids_.size());
  for (const std::int64_t id : var_ids_) x.push_back(est.at(id));
  return x;
}

void Problem::store(const std::vector<Pose2D>& x, Estimate2D* est) const {
  for (std::size_t k = 0; k < var_ids_.size(); ++k) (*est)[var_ids_[k]] = x[k];
}

double Problem::chi2(const std::vector<Pose2D>& x) const {
  double sum = 0.0;
  for (const Term& t : terms_) {
    const Eigen::Vector3d r =
        t.whiten *
        edgeErrorG2o(pose(x, t.vi, t.edge->from), pose(x, t.vj, t.edge->to), t.edge->measurement);
    sum += r.squaredNorm();
  }
  return sum;
}

double Problem::linearize(const std::vector<Pose2D>& x, SpMat* h, Eigen::VectorXd* g) const {
  double* val = h->valuePtr();
  std::fill(val, val + h->nonZeros(), 0.0);
  g->setZero(3 * numVariables());
  double sum = 0.0;
  for (const Term& t : terms_) {
    const Pose2D& xi = pose(x, t.vi, t.edge->from);
    const Pose2D& xj = pose(x, t.vj, t.edge->to);
    const Eigen::Vector3d r = t.whiten * edgeErrorG2o(xi, xj, t.edge->measurement);
    sum += r.squaredNorm();
    if (t.vi < 0 && t.vj < 0) continue;
    Eigen::Matrix3d ji;
    Eigen::Matrix3d jj;
    edgeJacobiansG2o(xi, xj, t.edge->measurement, &ji, &jj);
    const Eigen::Matrix3d ai = t.whiten * ji;
    const Eigen::Matrix3d aj = t.whiten * jj;
    blocks_.addTerm(t.vi, t.vj, t.off_block, r, ai, aj, val, g);
  }
  return sum;
}

std::vector<Pose2D> Problem::applyStep(const std::vector<Pose2D>& x,
                                       const Eigen::VectorXd& dx) const {
  std::vector<Pose2D> out(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    out[k] = retract2D(x[k], dx.segment<3>(3 * static_cast<Eigen::Index>(k)));
  }
  return out;
}

}  // namespace

BatchResult solveBatch2D(const Dataset2D& d, const Estimate2D& initial,
                         const BatchOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  BatchResult res;
  res.poses = initial;
  res.chi2_initial = chi2G2o(d, initial);

  const Problem problem(d, initial, options);
  std::vector<Pose2D> x = problem.variables(initial);
  const auto finish = [&](bool converged, std::string reason) {
    problem.store(x, &res.poses);
    res.chi2 = chi2G2o(d, res.poses);
    res.converged = converged;
    res.stop_reason = std::move(reason);
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return res;
  };
  if (problem.numVariables() == 0) return finish(true, "no variables (all poses fixed)");
  const batch_detail::SolveOutcome out = batch_detail::runGaussNewtonLm(problem, &x, options);
  res.iterations = out.iterations;
  return finish(out.converged, out.stop_reason);
}

}  // namespace lslam::sim
