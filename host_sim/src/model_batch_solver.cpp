#include "host_sim/model_batch_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
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

namespace {

using batch_detail::BlockPattern;
using batch_detail::SpMat;

// Central-difference step per tangent coordinate: balances truncation (h^2) against the rounding
// of t + R d for translations of up to ~1e2 m (eps |t| / h).
constexpr double kDiffStep = 1e-5;
constexpr int kMaxError = 6;
constexpr int kMaxParams = 7;

using ErrorVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxError, 1>;
using ErrorMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxError, kMaxError>;

// x (+) d written into out (parameterCount(kind) values).
void retractRaw(VariableKind kind, const double* x, const double* d, double* out) {
  switch (kind) {
    case VariableKind::SE2: {
      const Pose2D p = retract2D(Pose2D{x[0], x[1], x[2]}, Eigen::Vector3d(d[0], d[1], d[2]));
      out[0] = p.x;
      out[1] = p.y;
      out[2] = p.theta;
      return;
    }
    case VariableKind::Point2:
    case VariableKind::Point3:
      for (int k = 0; k < tangentDimension(kind); ++k) out[k] = x[k] + d[k];
      return;
    case VariableKind::SE3: {
      const Eigen::Quaterniond q = Eigen::Quaterniond(x[6], x[3], x[4], x[5]).normalized();
      const Eigen::Vector3d w(d[3], d[4], d[5]);
      const double angle = w.norm();
      const Eigen::Quaterniond dq = angle > 0.0
                                        ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle))
                                        : Eigen::Quaterniond::Identity();
      const Eigen::Vector3d t =
          Eigen::Vector3d(x[0], x[1], x[2]) + q * Eigen::Vector3d(d[0], d[1], d[2]);
      const Eigen::Quaterniond qn = (q * dq).normalized();
      out[0] = t.x();
      out[1] = t.y();
      out[2] = t.z();
      out[3] = qn.x();
      out[4] = qn.y();
      out[5] = qn.z();
      out[6] = qn.w();
      return;
    }
  }
}

struct Variable {
  VariableKey key;
  VariableKind kind = VariableKind::SE2;
  int param = 0;      // offset in the state vector
  int position = -1;  // block position after the COLAMD permutation; -1 = fixed
};

// One factor as the solver sees it.
struct Term {
  const ModelFactor* factor = nullptr;
  int var[2] = {-1, -1};  // indices into Problem::vars_ (var[1] = -1 for a prior)
  int dim = 0;            // error dimension
  ErrorMat whiten;        // R with Omega = R^T R
  int off_block = -1;
  bool angular[kMaxError] = {};
};

class Problem {
 public:
  Problem(const ModelDataset& d, const ModelEstimate& initial, const BatchOptions& options);

  int numFree() const { return blocks_.numBlocks(); }
  double chi2(const Eigen::VectorXd& x) const;
  double linearize(const Eigen::VectorXd& x, SpMat* h, Eigen::VectorXd* g) const;
  Eigen::VectorXd applyStep(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const;
  const SpMat& pattern() const { return blocks_.pattern(); }
  const std::vector<int>& diagOffsets() const { return blocks_.diagOffsets(); }
  const Eigen::VectorXd& start() const { return start_; }
  void store(const Eigen::VectorXd& x, ModelEstimate* est) const;
  const std::vector<VariableKey>& fixed() const { return fixed_; }

 private:
  void error(const Term& t, const double* a, const double* b, double* e) const {
    factorErrorRaw(convention_, t.factor->kind, a, b, t.factor->measurement.data(), e);
  }
  const double* param(const Eigen::VectorXd& x, int var) const {
    return var < 0 ? nullptr : x.data() + vars_[static_cast<std::size_t>(var)].param;
  }

  ObjectiveConvention convention_ = ObjectiveConvention::G2o;
  std::vector<Variable> vars_;
  std::vector<int> free_;  // position -> index into vars_
  std::vector<Term> terms_;
  std::vector<VariableKey> fixed_;
  Eigen::VectorXd start_;
  BlockPattern blocks_{std::vector<int>{}};
};

Problem::Problem(const ModelDataset& d, const ModelEstimate& initial, const BatchOptions& options)
    : convention_(d.convention) {
  const auto kinds = variableKinds(d);

  // Every key referenced by a factor, first-seen order, with its initial value.
  std::unordered_map<VariableKey, int, VariableKeyHash> index;
  int n_params = 0;
  for (const ModelFactor& f : d.factors) {
    if (f.information.rows() != errorDimension(f.kind) ||
        f.information.cols() != errorDimension(f.kind) ||
        f.measurement.size() != measurementSize(f.kind)) {
      throw std::invalid_argument(std::string("solveModelBatch: ") + factorKindName(f.kind) +
                                  " (line " + std::to_string(f.line) +
                                  ") has a measurement or information of the wrong size");
    }
    for (int s = 0; s < arity(f.kind); ++s) {
      const VariableKey& key = s == 0 ? f.first : f.second;
      if (index.count(key) != 0) continue;
      const auto it = initial.find(key);
      const VariableKind kind = kinds.at(key);
      const std::string name = std::string(key.role == VariableRole::Pose ? "pose " : "landmark ") +
                               std::to_string(key.id) + " (" + factorKindName(f.kind) + " line " +
                               std::to_string(f.line) + ")";
      if (it == initial.end()) {
        throw std::invalid_argument("solveModelBatch: " + name + " has no initial value");
      }
      if (it->second.size() != parameterCount(kind)) {
        throw std::invalid_argument("solveModelBatch: " + name + ": initial value of size " +
                                    std::to_string(it->second.size()) + ", expected " +
                                    std::to_string(parameterCount(kind)));
      }
      index[key] = static_cast<int>(vars_.size());
      vars_.push_back(Variable{key, kind, n_params, -1});
      n_params += parameterCount(kind);
    }
  }
  start_.resize(n_params);
  for (const Variable& v : vars_) {
    start_.segment(v.param, parameterCount(v.kind)) = initial.at(v.key);
  }

  // The gauge.
  std::unordered_set<VariableKey, VariableKeyHash> fixed;
  for (const std::int64_t id : options.fixed) fixed.insert(VariableKey{VariableRole::Pose, id});
  if (fixed.empty()) {
    for (const VariableKey& k : d.fixed) {
      if (k.role == VariableRole::Pose) fixed.insert(k);
    }
  }
  if (fixed.empty()) {
    bool any = false;
    std::int64_t smallest = std::numeric_limits<std::int64_t>::max();
    for (const Variable& v : vars_) {
      if (v.key.role != VariableRole::Pose) continue;
      any = true;
      smallest = std::min(smallest, v.key.id);
    }
    if (any) fixed.insert(VariableKey{VariableRole::Pose, smallest});
  }

  // Free variables sorted by (role, id) before the ordering.
  std::vector<int> ids;  // indices into vars_
  for (std::size_t k = 0; k < vars_.size(); ++k) {
    if (fixed.count(vars_[k].key) != 0) {
      fixed_.push_back(vars_[k].key);
    } else {
      ids.push_back(static_cast<int>(k));
    }
  }
  std::sort(ids.begin(), ids.end(), [&](int a, int b) {
    const VariableKey& ka = vars_[static_cast<std::size_t>(a)].key;
    const VariableKey& kb = vars_[static_cast<std::size_t>(b)].key;
    if (ka.role != kb.role) return ka.role == VariableRole::Pose;
    return ka.id < kb.id;
  });
  std::sort(fixed_.begin(), fixed_.end(),
            [](const VariableKey& a, const VariableKey& b) { return a.id < b.id; });
  std::vector<int> rank(vars_.size(), -1);  // vars_ index -> index in ids
  for (std::size_t k = 0; k < ids.size(); ++k) {
    rank[static_cast<std::size_t>(ids[k])] = static_cast<int>(k);
  }

  // COLAMD on the block structure of A: one row per factor with a variable, one column per
  // variable.
  const int n = static_cast<int>(ids.size());
  std::vector<std::vector<int>> col_rows(static_cast<std::size_t>(n));
  int n_row = 0;
  for (const ModelFactor& f : d.factors) {
    const int a = rank[static_cast<std::size_t>(index.at(f.first))];
    const int b = arity(f.kind) == 2 ? rank[static_cast<std::size_t>(index.at(f.second))] : -1;
    if (a < 0 && b < 0) continue;
    if (a >= 0) col_rows[static_cast<std::size_t>(a)].push_back(n_row);
    if (b >= 0 && b != a) col_rows[static_cast<std::size_t>(b)].push_back(n_row);
    ++n_row;
  }
  const std::vector<int> perm = batch_detail::colamdOrdering(n_row, col_rows, "solveModelBatch");
  std::vector<int> sizes(static_cast<std::size_t>(n));
  free_.resize(static_cast<std::size_t>(n));
  for (int p = 0; p < n; ++p) {
    const int v = ids[static_cast<std::size_t>(perm[static_cast<std::size_t>(p)])];
    vars_[static_cast<std::size_t>(v)].position = p;
    free_[static_cast<std::size_t>(p)] = v;
    sizes[static_cast<std::size_t>(p)] = tangentDimension(vars_[static_cast<std::size_t>(v)].kind);
  }
  blocks_ = BlockPattern(std::move(sizes));

  // Terms.
  terms_.reserve(d.factors.size());
  for (const ModelFactor& f : d.factors) {
    Term t;
    t.factor = &f;
    t.dim = errorDimension(f.kind);
    t.var[0] = index.at(f.first);
    if (arity(f.kind) == 2) t.var[1] = index.at(f.second);
    for (int k = 0; k < t.dim; ++k) t.angular[k] = isAngularErrorComponent(convention_, f.kind, k);
    const Eigen::MatrixXd omega = 0.5 * (f.information + f.information.transpose());
    Eigen::LLT<Eigen::MatrixXd> llt(omega);
    if (!omega.allFinite() || llt.info() != Eigen::Success) {
      throw std::invalid_argument(std::string("solveModelBatch: information matrix of ") +
                                  factorKindName(f.kind) + " (line " + std::to_string(f.line) +
                                  ") is not positive definite");
    }
    t.whiten = llt.matrixU();  // Omega = U^T U
    const int pa = vars_[static_cast<std::size_t>(t.var[0])].position;
    const int pb = t.var[1] >= 0 ? vars_[static_cast<std::size_t>(t.var[1])].position : -1;
    if (pa >= 0 && pb >= 0 && pa != pb) t.off_block = blocks_.offDiagonal(pa, pb);
    terms_.push_back(t);
  }
  blocks_.finalize();
}

double Problem::chi2(const Eigen::VectorXd& x) const {
  double sum = 0.0;
  double e[kMaxError];
  for (const Term& t : terms_) {
    error(t, param(x, t.var[0]), param(x, t.var[1]), e);
    const ErrorVec r = t.whiten * Eigen::Map<const ErrorVec>(e, t.dim);
    sum += r.squaredNorm();
  }
  return sum;
}

double Problem::linearize(const Eigen::VectorXd& x, SpMat* h, Eigen::VectorXd* g) const {
  double* val = h->valuePtr();
  std::fill(val, val + h->nonZeros(), 0.0);
  g->setZero(blocks_.dimension());
  double sum = 0.0;
  double e[kMaxError];
  double ep[kMaxError];
  double em[kMaxError];
  double buf[kMaxParams];
  double delta[BlockPattern::kMaxBlock];
  for (const Term& t : terms_) {
    const double* args[2] = {param(x, t.var[0]), param(x, t.var[1])};
    error(t, args[0], args[1], e);
    const ErrorVec r = t.whiten * Eigen::Map<const ErrorVec>(e, t.dim);
    sum += r.squaredNorm();
    int pos[2] = {-1, -1};
    ErrorMat jac[2];
    for (int s = 0; s < 2; ++s) {
      if (t.var[s] < 0) continue;
      const Variable& v = vars_[static_cast<std::size_t>(t.var[s])];
      pos[s] = v.position;
      if (v.position < 0) continue;
      const int td = tangentDimension(v.kind);
      ErrorMat j(t.dim, td);
      std::fill(delta, delta + td, 0.0);
      for (int k = 0; k < td; ++k) {
        const double* perturbed[2] = {args[0], args[1]};
        perturbed[s] = buf;
        delta[k] = kDiffStep;
        retractRaw(v.kind, args[s], delta, buf);
        error(t, perturbed[0], perturbed[1], ep);
        delta[k] = -kDiffStep;
        retractRaw(v.kind, args[s], delta, buf);
        error(t, perturbed[0], perturbed[1], em);
        delta[k] = 0.0;
        for (int i = 0; i < t.dim; ++i) {
          const double diff = t.angular[i] ? wrapAngle(ep[i] - em[i]) : ep[i] - em[i];
          j(i, k) = diff / (2.0 * kDiffStep);
        }
      }
      jac[s] = t.whiten * j;
    }
    if (pos[0] < 0 && pos[1] < 0) continue;
    blocks_.addTerm(pos[0], pos[1], t.off_block, r, jac[0], jac[1], val, g);
  }
  return sum;
}

Eigen::VectorXd Problem::applyStep(const Eigen::VectorXd& x, const Eigen::VectorXd& dx) const {
  Eigen::VectorXd out = x;
  for (int p = 0; p < numFree(); ++p) {
    const Variable& v = vars_[static_cast<std::size_t>(free_[static_cast<std::size_t>(p)])];
    retractRaw(v.kind, x.data() + v.param, dx.data() + blocks_.offset(p), out.data() + v.param);
  }
  return out;
}

void Problem::store(const Eigen::VectorXd& x, ModelEstimate* est) const {
  for (const Variable& v : vars_) (*est)[v.key] = x.segment(v.param, parameterCount(v.kind));
}

}  // namespace

Eigen::VectorXd retractModel(VariableKind kind, const Eigen::VectorXd& x,
                             const Eigen::VectorXd& delta) {
  if (x.size() != parameterCount(kind) || delta.size() != tangentDimension(kind)) {
    throw std::invalid_argument("retractModel: wrong value or increment size");
  }
  Eigen::VectorXd out(parameterCount(kind));
  retractRaw(kind, x.data(), delta.data(), out.data());
  return out;
}

ModelBatchResult solveModelBatch(const ModelDataset& d, const ModelEstimate& initial,
                                 const BatchOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  ModelBatchResult res;
  res.values = initial;
  const Problem problem(d, initial, options);
  res.chi2_initial = chi2(d, initial);
  res.fixed = problem.fixed();
  Eigen::VectorXd x = problem.start();
  const auto finish = [&](bool converged, std::string reason) {
    problem.store(x, &res.values);
    res.chi2 = chi2(d, res.values);
    res.converged = converged;
    res.stop_reason = std::move(reason);
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return res;
  };
  if (problem.numFree() == 0) return finish(true, "no variables (all poses fixed)");
  const batch_detail::SolveOutcome out = batch_detail::runGaussNewtonLm(problem, &x, options);
  res.iterations = out.iterations;
  return finish(out.converged, out.stop_reason);
}

}  // namespace lslam::sim
