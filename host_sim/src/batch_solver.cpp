#include "host_sim/batch_solver.h"

#include <colamd.h>

#include <Eigen/Cholesky>
#include <Eigen/Sparse>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>
#include <utility>

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

using SpMat = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using Llt = Eigen::SimplicialLLT<SpMat, Eigen::Lower, Eigen::NaturalOrdering<int>>;

// One edge as the solver sees it. Variable positions are after the COLAMD permutation; -1 = fixed.
struct Term {
  const Edge2D* edge = nullptr;
  int vi = -1;
  int vj = -1;
  Eigen::Matrix3d whiten;  // R with Omega = R^T R
  // Offsets into H's value array (lower triangle, CSC) of the blocks this edge touches:
  // diag blocks of vi and vj, and the off-diagonal block (max(vi,vj), min(vi,vj)).
  int off_block = -1;  // index into Problem::blocks, -1 if none
};

// A 3x3 block (row block br >= column block bc) of the lower triangle of H: value offsets of the
// first stored entry of each of its three columns. For a diagonal block column c holds rows c..2.
struct Block {
  int br = 0;
  int bc = 0;
  int col_start[3] = {0, 0, 0};
};

class Problem {
 public:
  Problem(const Dataset2D& d, const Estimate2D& initial, const BatchOptions& options);

  int numVariables() const { return static_cast<int>(var_ids_.size()); }
  // Whitened chi2 at `x` (vector of variable poses in position order).
  double chi2(const std::vector<Pose2D>& x) const;
  // Fills H (values only; the pattern is fixed) and g = J^T r; returns chi2 at x.
  double linearize(const std::vector<Pose2D>& x, SpMat* h, Eigen::VectorXd* g) const;
  const SpMat& pattern() const { return pattern_; }
  const std::vector<int>& diagOffsets() const { return diag_offset_; }
  std::vector<Pose2D> variables(const Estimate2D& est) const;
  void store(const std::vector<Pose2D>& x, Estimate2D* est) const;

 private:
  const Pose2D& pose(const std::vector<Pose2D>& x, int v, std::int64_t id) const {
    return v >= 0 ? x[static_cast<std::size_t>(v)] : fixed_pose_.at(id);
  }
  std::vector<std::int64_t> var_ids_;  // position -> id
  std::unordered_map<std::int64_t, Pose2D> fixed_pose_;
  std::vector<Term> terms_;
  std::vector<Block> blocks_;  // diagonal blocks first: blocks_[v] is (v, v)
  SpMat pattern_;
  std::vector<int> diag_offset_;  // scalar k -> offset of H(k, k)
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
  std::vector<int> perm(static_cast<std::size_t>(n));  // position -> index in ids
  if (n > 0) {
    std::vector<std::vector<int>> col_rows(static_cast<std::size_t>(n));
    int n_row = 0;
    int nnz = 0;
    for (const Edge2D& e : d.edges) {
      const int a = indexOf(e.from);
      const int b = indexOf(e.to);
      if (a < 0 && b < 0) continue;
      if (a >= 0) col_rows[static_cast<std::size_t>(a)].push_back(n_row), ++nnz;
      if (b >= 0 && b != a) col_rows[static_cast<std::size_t>(b)].push_back(n_row), ++nnz;
      ++n_row;
    }
    const std::size_t alen = colamd_recommended(nnz, n_row, n);
    if (alen == 0) throw std::runtime_error("solveBatch2D: colamd_recommended failed");
    std::vector<int> a_rows(alen, 0);
    std::vector<int> p(static_cast<std::size_t>(n) + 1, 0);
    int k = 0;
    for (int c = 0; c < n; ++c) {
      p[static_cast<std::size_t>(c)] = k;
      for (const int r : col_rows[static_cast<std::size_t>(c)])
        a_rows[static_cast<std::size_t>(k++)] = r;
    }
    p[static_cast<std::size_t>(n)] = k;
    double knobs[COLAMD_KNOBS];
    int stats[COLAMD_STATS];
    colamd_set_defaults(knobs);
    if (colamd(n_row, n, static_cast<int>(alen), a_rows.data(), p.data(), knobs, stats) == 0) {
      throw std::runtime_error("solveBatch2D: colamd failed (status " + std::to_string(stats[3]) +
                               ")");
    }
    for (int c = 0; c < n; ++c) perm[static_cast<std::size_t>(c)] = p[static_cast<std::size_t>(c)];
  }
  std::vector<int> pos(static_cast<std::size_t>(n));  // index in ids -> position
  var_ids_.resize(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    pos[static_cast<std::size_t>(perm[static_cast<std::size_t>(k)])] = k;
    var_ids_[static_cast<std::size_t>(k)] =
        ids[static_cast<std::size_t>(perm[static_cast<std::size_t>(k)])];
  }

  // Terms and the block pattern of the lower triangle of H.
  for (int v = 0; v < n; ++v) blocks_.push_back(Block{v, v, {0, 0, 0}});
  std::unordered_map<std::uint64_t, int> block_of;
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
    if (t.vi >= 0 && t.vj >= 0 && t.vi != t.vj) {
      const int br = std::max(t.vi, t.vj);
      const int bc = std::min(t.vi, t.vj);
      const std::uint64_t key =
          (static_cast<std::uint64_t>(br) << 32) | static_cast<std::uint64_t>(bc);
      const auto [it, inserted] = block_of.emplace(key, static_cast<int>(blocks_.size()));
      if (inserted) blocks_.push_back(Block{br, bc, {0, 0, 0}});
      t.off_block = it->second;
    }
    terms_.push_back(t);
  }

  // Scalar pattern: all 9 entries of off-diagonal blocks, the lower 6 of diagonal blocks.
  const int dim = 3 * n;
  std::vector<Eigen::Triplet<double, int>> trip;
  trip.reserve(blocks_.size() * 9);
  for (const Block& blk : blocks_) {
    for (int c = 0; c < 3; ++c) {
      for (int r = (blk.br == blk.bc ? c : 0); r < 3; ++r) {
        trip.emplace_back(3 * blk.br + r, 3 * blk.bc + c, 0.0);
      }
    }
  }
  pattern_.resize(dim, dim);
  pattern_.setFromTriplets(trip.begin(), trip.end());
  pattern_.makeCompressed();
  const auto offsetOf = [&](int row, int col) {
    const int* inner = pattern_.innerIndexPtr();
    const int* begin = inner + pattern_.outerIndexPtr()[col];
    const int* end = inner + pattern_.outerIndexPtr()[col + 1];
    const int* it = std::lower_bound(begin, end, row);
    if (it == end || *it != row) throw std::logic_error("solveBatch2D: pattern entry missing");
    return static_cast<int>(it - inner);
  };
  for (Block& blk : blocks_) {
    for (int c = 0; c < 3; ++c) {
      blk.col_start[c] = offsetOf(3 * blk.br + (blk.br == blk.bc ? c : 0), 3 * blk.bc + c);
    }
  }
  diag_offset_.resize(static_cast<std::size_t>(dim));
  for (int k = 0; k < dim; ++k) diag_offset_[static_cast<std::size_t>(k)] = offsetOf(k, k);
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
  const auto addBlock = [&](const Block& blk, const Eigen::Matrix3d& m) {
    // m is block (br, bc) of H.
    if (blk.br == blk.bc) {
      for (int c = 0; c < 3; ++c) {
        for (int r = c; r < 3; ++r) val[blk.col_start[c] + (r - c)] += m(r, c);
      }
    } else {
      for (int c = 0; c < 3; ++c) {
        for (int r = 0; r < 3; ++r) val[blk.col_start[c] + r] += m(r, c);
      }
    }
  };
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
    if (t.vi >= 0 && t.vi == t.vj) {  // an edge from a pose to itself
      const Eigen::Matrix3d a = ai + aj;
      addBlock(blocks_[static_cast<std::size_t>(t.vi)], a.transpose() * a);
      g->segment<3>(3 * t.vi) += a.transpose() * r;
      continue;
    }
    if (t.vi >= 0) {
      addBlock(blocks_[static_cast<std::size_t>(t.vi)], ai.transpose() * ai);
      g->segment<3>(3 * t.vi) += ai.transpose() * r;
    }
    if (t.vj >= 0) {
      addBlock(blocks_[static_cast<std::size_t>(t.vj)], aj.transpose() * aj);
      g->segment<3>(3 * t.vj) += aj.transpose() * r;
    }
    if (t.off_block >= 0) {
      // Block (max, min): A_max^T A_min.
      const Block& blk = blocks_[static_cast<std::size_t>(t.off_block)];
      addBlock(blk, t.vi > t.vj ? Eigen::Matrix3d(ai.transpose() * aj)
                                : Eigen::Matrix3d(aj.transpose() * ai));
    }
  }
  return sum;
}

std::vector<Pose2D> applyStep(const std::vector<Pose2D>& x, const Eigen::VectorXd& dx) {
  std::vector<Pose2D> out(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    out[k] = retract2D(x[k], dx.segment<3>(3 * static_cast<Eigen::Index>(k)));
  }
  return out;
}

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
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

  SpMat h = problem.pattern();
  SpMat s = problem.pattern();  // H + lambda diag(H)
  Eigen::VectorXd g;
  Llt llt;
  llt.analyzePattern(h);
  double chi2 = problem.linearize(x, &h, &g);
  const std::vector<int>& diag = problem.diagOffsets();
  const auto factorize = [&](double lambda) {
    std::copy(h.valuePtr(), h.valuePtr() + h.nonZeros(), s.valuePtr());
    if (lambda != 0.0) {
      double* sv = s.valuePtr();
      for (const int k : diag) sv[k] += lambda * sv[k];
    }
    llt.factorize(s);
    return llt.info() == Eigen::Success;
  };
  // The undamped Gauss-Newton model at the current point: its step norm and the chi2 decrease it
  // predicts, g^T H^-1 g. Used to confirm a stop before calling it converged.
  struct Model {
    bool ok = false;
    double step = std::numeric_limits<double>::infinity();
    double predicted = std::numeric_limits<double>::infinity();
  };
  const auto undampedModel = [&]() {
    Model m;
    if (!factorize(0.0)) return m;
    const Eigen::VectorXd dx = llt.solve(-g);
    if (!dx.allFinite()) return m;
    m.ok = true;
    m.step = dx.norm();
    m.predicted = std::max(0.0, -g.dot(dx));
    return m;
  };
  const auto describe = [](const Model& m) {
    return m.ok ? "undamped step " + fmt(m.step) + ", predicted chi2 decrease " + fmt(m.predicted)
                : std::string("undamped normal equations singular");
  };
  const std::string max_it_reason =
      "max_iterations (" + std::to_string(options.max_iterations) + ") reached before convergence";

  if (options.method == BatchMethod::GaussNewton) {
    while (true) {
      ++res.iterations;
      if (!factorize(0.0)) {
        return finish(false,
                      "Cholesky of the normal equations failed (not positive definite: "
                      "unconstrained gauge or disconnected graph?)");
      }
      const Eigen::VectorXd dx = llt.solve(-g);
      if (!dx.allFinite()) return finish(false, "non-finite Gauss-Newton step");
      if (dx.norm() < options.step_tolerance) {
        return finish(true, "step norm " + fmt(dx.norm()) + " < step_tolerance");
      }
      x = applyStep(x, dx);
      const double chi2_old = chi2;
      chi2 = problem.linearize(x, &h, &g);
      if (!std::isfinite(chi2)) return finish(false, "diverged (non-finite chi2)");
      if (chi2 == 0.0) return finish(true, "chi2 is zero");
      if (std::abs(chi2_old - chi2) <= options.gn_relative_decrease_tolerance * chi2_old) {
        // Confirm with the model at the new point (a GN iterate can pass through a point where
        // chi2 happens to change little without being stationary).
        const Model m = undampedModel();
        if (m.ok && (m.step < options.step_tolerance ||
                     m.predicted <= options.gn_relative_decrease_tolerance * chi2)) {
          return finish(true, "relative chi2 change below gn_relative_decrease_tolerance (" +
                                  describe(m) + ")");
        }
      }
      if (res.iterations >= options.max_iterations) return finish(false, max_it_reason);
    }
  }

  // Levenberg-Marquardt, seed section 3.1.
  double lambda = options.lambda_initial;
  double error = std::sqrt(chi2);  // seed: norm(b)
  // The step rule and the decrease rule end the run (converged) only if the undamped model at the
  // current point agrees: its step is below step_tolerance or the error decrease it predicts is
  // below error_decrease_tolerance. Otherwise the rule fired because of the damping or a slow
  // stretch, not because the point is stationary, and the iteration goes on.
  std::string last_unconfirmed;
  const auto confirmed = [&](Model* m) {
    *m = undampedModel();
    const double predicted_error_decrease = error - std::sqrt(std::max(0.0, chi2 - m->predicted));
    return m->ok && (m->step < options.step_tolerance ||
                     predicted_error_decrease < options.error_decrease_tolerance);
  };
  const auto notConverged = [&](const std::string& reason) {
    return finish(false, last_unconfirmed.empty()
                             ? reason
                             : reason + "; last unconfirmed stop: " + last_unconfirmed);
  };
  while (true) {
    ++res.iterations;
    bool accepted = false;
    Eigen::VectorXd dm;
    if (factorize(lambda)) dm = llt.solve(-g);
    if (dm.size() > 0 && dm.allFinite()) {
      const double step = dm.norm();
      if (step < options.step_tolerance) {
        const std::string rule = "step norm " + fmt(step) + " < step_tolerance";
        Model m;
        if (confirmed(&m)) {
          return finish(true, rule + " (lambda " + fmt(lambda) + ", " + describe(m) + ")");
        }
        last_unconfirmed = rule + " (lambda " + fmt(lambda) + ", " + describe(m) + ")";
      }
      std::vector<Pose2D> x_new = applyStep(x, dm);
      const double next_error = std::sqrt(problem.chi2(x_new));
      if (std::isfinite(next_error) && next_error <= error && lambda <= options.lambda_max) {
        const double decrease = error - next_error;
        x = std::move(x_new);
        error = next_error;
        chi2 = problem.linearize(x, &h, &g);
        lambda /= options.lambda_factor;
        accepted = true;
        if (decrease < options.error_decrease_tolerance) {
          const std::string rule = "error decrease " + fmt(decrease) +
                                   " < error_decrease_tolerance at sqrt(chi2) " + fmt(error);
          Model m;
          if (confirmed(&m)) {
            return finish(true, rule + " (lambda " + fmt(lambda) + ", " + describe(m) + ")");
          }
          last_unconfirmed = rule + " (lambda " + fmt(lambda) + ", " + describe(m) + ")";
        }
      }
    }
    if (!accepted) {
      lambda *= options.lambda_factor;
      if (lambda > options.lambda_max) {
        return notConverged("lambda " + fmt(lambda) + " exceeded lambda_max " +
                            fmt(options.lambda_max) + " (no decreasing step found)");
      }
    }
    if (res.iterations >= options.max_iterations) return notConverged(max_it_reason);
  }
}

}  // namespace lslam::sim
