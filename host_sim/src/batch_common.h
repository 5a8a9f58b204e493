#pragma once
// Private to the batch reference solvers (batch_solver.cpp for 2D pose graphs,
// model_batch_solver.cpp for every model): the COLAMD ordering, the block pattern of the normal
// equations and the Gauss-Newton / Levenberg-Marquardt loop with its stopping rules. One copy, so
// that both solvers stop by exactly the same rules (documented in host_sim/batch_solver.h).
#include <colamd.h>

#include <Eigen/Core>
#include <Eigen/Sparse>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "host_sim/batch_solver.h"

namespace lslam::sim::batch_detail {

using SpMat = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using Llt = Eigen::SimplicialLLT<SpMat, Eigen::Lower, Eigen::NaturalOrdering<int>>;

inline std::string fmt(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

// COLAMD column ordering of a pattern given column by column (col_rows[c]: the rows with an entry
// in column c; n_row rows in all). Returns perm: position -> column. `who` prefixes errors.
inline std::vector<int> colamdOrdering(int n_row, const std::vector<std::vector<int>>& col_rows,
                                       const std::string& who) {
  const int n = static_cast<int>(col_rows.size());
  std::vector<int> perm(static_cast<std::size_t>(n));
  if (n == 0) return perm;
  int nnz = 0;
  for (const std::vector<int>& rows : col_rows) nnz += static_cast<int>(rows.size());
  const std::size_t alen = colamd_recommended(nnz, n_row, n);
  if (alen == 0) throw std::runtime_error(who + ": colamd_recommended failed");
  std::vector<int> a_rows(alen, 0);
  std::vector<int> p(static_cast<std::size_t>(n) + 1, 0);
  int k = 0;
  for (int c = 0; c < n; ++c) {
    p[static_cast<std::size_t>(c)] = k;
    for (const int r : col_rows[static_cast<std::size_t>(c)]) {
      a_rows[static_cast<std::size_t>(k++)] = r;
    }
  }
  p[static_cast<std::size_t>(n)] = k;
  double knobs[COLAMD_KNOBS];
  int stats[COLAMD_STATS];
  colamd_set_defaults(knobs);
  if (colamd(n_row, n, static_cast<int>(alen), a_rows.data(), p.data(), knobs, stats) == 0) {
    throw std::runtime_error(who + ": colamd failed (status " + std::to_string(stats[3]) + ")");
  }
  for (int c = 0; c < n; ++c) perm[static_cast<std::size_t>(c)] = p[static_cast<std::size_t>(c)];
  return perm;
}

// The block pattern of the lower triangle of H (CSC) for variables of block sizes `sizes` (in
// position order, each at most kMaxBlock): diagonal blocks (v, v) are blocks 0..n-1, off-diagonal
// blocks (max, min) are added by offDiagonal() before finalize().
class BlockPattern {
 public:
  static constexpr int kMaxBlock = 6;

  explicit BlockPattern(std::vector<int> sizes) : sizes_(std::move(sizes)) {
    offsets_.resize(sizes_.size());
    int dim = 0;
    for (std::size_t v = 0; v < sizes_.size(); ++v) {
      if (sizes_[v] < 1 || sizes_[v] > kMaxBlock) throw std::logic_error("BlockPattern: bad size");
      offsets_[v] = dim;
      dim += sizes_[v];
      blocks_.push_back(Block{static_cast<int>(v), static_cast<int>(v), {}});
    }
    dim_ = dim;
  }

  int numBlocks() const { return static_cast<int>(sizes_.size()); }
  int dimension() const { return dim_; }
  int offset(int v) const { return offsets_[static_cast<std::size_t>(v)]; }
  int size(int v) const { return sizes_[static_cast<std::size_t>(v)]; }

  // The block (max(a, b), min(a, b)), a != b, created on first use; returns its index.
  int offDiagonal(int a, int b) {
    const int br = std::max(a, b);
    const int bc = std::min(a, b);
    const std::uint64_t key =
        (static_cast<std::uint64_t>(br) << 32) | static_cast<std::uint64_t>(bc);
    const auto [it, inserted] = block_of_.emplace(key, static_cast<int>(blocks_.size()));
    if (inserted) blocks_.push_back(Block{br, bc, {}});
    return it->second;
  }

  // Builds the scalar pattern: all entries of off-diagonal blocks, the lower triangle of diagonal
  // blocks; and the value offsets used by add().
  void finalize() {
    std::vector<Eigen::Triplet<double, int>> trip;
    trip.reserve(blocks_.size() * kMaxBlock * kMaxBlock);
    for (const Block& blk : blocks_) {
      for (int c = 0; c < size(blk.bc); ++c) {
        for (int r = (blk.br == blk.bc ? c : 0); r < size(blk.br); ++r) {
          trip.emplace_back(offset(blk.br) + r, offset(blk.bc) + c, 0.0);
        }
      }
    }
    pattern_.resize(dim_, dim_);
    pattern_.setFromTriplets(trip.begin(), trip.end());
    pattern_.makeCompressed();
    const auto offsetOf = [&](int row, int col) {
      const int* inner = pattern_.innerIndexPtr();
      const int* begin = inner + pattern_.outerIndexPtr()[col];
      const int* end = inner + pattern_.outerIndexPtr()[col + 1];
      const int* it = std::lower_bound(begin, end, row);
      if (it == end || *it != row) throw std::logic_error("BlockPattern: pattern entry missing");
      return static_cast<int>(it - inner);
    };
    for (Block& blk : blocks_) {
      for (int c = 0; c < size(blk.bc); ++c) {
        blk.col_start[static_cast<std::size_t>(c)] =
            offsetOf(offset(blk.br) + (blk.br == blk.bc ? c : 0), offset(blk.bc) + c);
      }
    }
    diag_offset_.resize(static_cast<std::size_t>(dim_));
    for (int k = 0; k < dim_; ++k) diag_offset_[static_cast<std::size_t>(k)] = offsetOf(k, k);
  }

  const SpMat& pattern() const { return pattern_; }
  const std::vector<int>& diagOffsets() const { return diag_offset_; }

  // Adds m (block `blk` of H, size(br) x size(bc)) to H's values; a diagonal block's upper part is
  // not read.
  template <class M>
  void add(int blk_index, const M& m, double* val) const {
    const Block& blk = blocks_[static_cast<std::size_t>(blk_index)];
    const bool diag = blk.br == blk.bc;
    for (int c = 0; c < size(blk.bc); ++c) {
      const int start = blk.col_start[static_cast<std::size_t>(c)];
      for (int r = diag ? c : 0; r < size(blk.br); ++r)
        val[start + (r - (diag ? c : 0))] += m(r, c);
    }
  }

  // Adds one term's whitened residual r and Jacobians ai (w.r.t. variable vi) and aj (vj) to H and
  // g = J^T r. vi or vj = -1: that variable is fixed (its Jacobian is not read); vi == vj: a term
  // from a variable to itself; off_block: the index of block (max, min) when both are variables.
  template <class R, class A, class B>
  void addTerm(int vi, int vj, int off_block, const R& r, const A& ai, const B& aj, double* val,
               Eigen::VectorXd* g) const {
    if (vi >= 0 && vi == vj) {
      const auto a = (ai + aj).eval();
      add(vi, (a.transpose() * a).eval(), val);
      g->segment(offset(vi), size(vi)) += a.transpose() * r;
      return;
    }
    if (vi >= 0) {
      add(vi, (ai.transpose() * ai).eval(), val);
      g->segment(offset(vi), size(vi)) += ai.transpose() * r;
    }
    if (vj >= 0) {
      add(vj, (aj.transpose() * aj).eval(), val);
      g->segment(offset(vj), size(vj)) += aj.transpose() * r;
    }
    if (off_block >= 0) {
      // Block (max, min): A_max^T A_min.
      if (vi > vj) {
        add(off_block, (ai.transpose() * aj).eval(), val);
      } else {
        add(off_block, (aj.transpose() * ai).eval(), val);
      }
    }
  }

 private:
  struct Block {
    int br = 0;
    int bc = 0;
    // Value offset of the first stored entry of each column (a diagonal block's column c holds rows
    // c..size-1).
    std::array<int, kMaxBlock> col_start{};
  };
  std::vector<int> sizes_;
  std::vector<int> offsets_;
  int dim_ = 0;
  std::vector<Block> blocks_;
  std::unordered_map<std::uint64_t, int> block_of_;
  SpMat pattern_;
  std::vector<int> diag_offset_;
};

struct SolveOutcome {
  int iterations = 0;
  bool converged = false;
  std::string stop_reason;
};

// The Gauss-Newton / Levenberg-Marquardt loop and its stopping rules (batch_solver.h, solveBatch2D)
// on `problem`, from *x (updated in place to the final estimate). Problem provides
//   double linearize(const State&, SpMat* h, Eigen::VectorXd* g) const;  // H, g = J^T r; chi2
//   double chi2(const State&) const;
//   State applyStep(const State&, const Eigen::VectorXd& dx) const;     // the retraction
//   const SpMat& pattern() const;  const std::vector<int>& diagOffsets() const;
// and has at least one variable.
template <class Problem, class State>
SolveOutcome runGaussNewtonLm(const Problem& problem, State* x, const BatchOptions& options) {
  SolveOutcome res;
  const auto finish = [&](bool converged, std::string reason) {
    res.converged = converged;
    res.stop_reason = std::move(reason);
    return res;
  };

  SpMat h = problem.pattern();
  SpMat s = problem.pattern();  // H + lambda diag(H)
  Eigen::VectorXd g;
  Llt llt;
  llt.analyzePattern(h);
  double chi2 = problem.linearize(*x, &h, &g);
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
      *x = problem.applyStep(*x, dx);
      const double chi2_old = chi2;
      chi2 = problem.linearize(*x, &h, &g);
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
      State x_new = problem.applyStep(*x, dm);
      const double next_error = std::sqrt(problem.chi2(x_new));
      if (std::isfinite(next_error) && next_error <= error && lambda <= options.lambda_max) {
        const double decrease = error - next_error;
        *x = std::move(x_new);
        error = next_error;
        chi2 = problem.linearize(*x, &h, &g);
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

}  // namespace lslam::sim::batch_detail
