#pragma once
// The independent batch reference solver for 2D pose graphs (Gauss-Newton and the seed's
// Levenberg-Marquardt, toolbox section 3.1). Host-only. It shares no linear algebra and no geometry
// with firmware_lib (no lslam/ header is included): it is the reference the incremental solver is
// checked against. Sparse normal equations, SuiteSparse COLAMD ordering on the pose-block structure
// of the Jacobian, Eigen::SimplicialLLT factorisation (symbolic analysis done once per solve).
//
// Objective: the g2o chi2 of host_sim/chi2.h, chi2 = sum_k e_k^T Omega_k e_k with
// e_k = (x, y, theta) of Z^-1 Xi^-1 Xj (theta wrapped to (-pi, pi]).
//
// Retraction (the on-manifold perturbation the Jacobians are taken with):
//   x (+) d = x o d = (x + R(theta) * d_xy, wrap(theta + d_theta)),
// i.e. the pose x composed on the right with the increment d read as a pose (a body-frame
// translation followed by a rotation). It is not SE(2)'s Exp; it agrees with X*Exp(d) to first
// order, so the optimum and the chi2 are the same.
//
// Whitening: Omega = R^T R with R = L^T from a 3x3 LLT of Omega (per edge); the solver minimises
// ||R e||^2 = chi2. An information matrix that is not positive definite is rejected
// (std::invalid_argument).
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "host_sim/chi2.h"
#include "host_sim/dataset.h"

namespace lslam::sim {

enum class BatchMethod { GaussNewton, LevenbergMarquardt };

struct BatchOptions {
  BatchMethod method = BatchMethod::LevenbergMarquardt;
  // Upper bound on linear solves (for LM, rejected trial steps count as iterations, as in the
  // seed's loop counter). The step of the last iteration is still evaluated (and, for LM, accepted
  // if it lowers the error) before the solver stops with converged = false.
  int max_iterations = 500;
  // Seed: stop when norm(dm) < tol (the tiny step is not applied). For LM this counts as
  // convergence only when the damping is not what made the step small (see solveBatch2D).
  double step_tolerance = 1e-9;
  // Seed: Solver.lambda, the initial damping of H + lambda * diag(H). The seed leaves the value to
  // the caller; 1e-5 (almost Gauss-Newton) is used here: on every test dataset the first steps are
  // then accepted or fixed by a few x10 rejections.
  double lambda_initial = 1e-5;
  double lambda_factor = 10.0;  // seed
  double lambda_max = 1e7;      // seed
  // Seed's rule: after an accepted LM step, stop (converged) if
  //   current_error - next_error < error_decrease_tolerance,
  // with error = norm(b) = sqrt(chi2) (the norm of the whitened residual vector, NOT chi2), an
  // absolute threshold. The seed's 0.005 stops a step or two before the optimum, by design. A
  // reference solver should stop at the numerical optimum, so the default is far below any real
  // progress: the run ends once the quadratic convergence has hit rounding. Set 0.005 to
  // reproduce the seed's rule exactly.
  double error_decrease_tolerance = 1e-10;
  // Gauss-Newton only: stop (converged) when |chi2_old - chi2_new| <= this * chi2_old after a step.
  double gn_relative_decrease_tolerance = 1e-12;
  // Poses held fixed (the gauge): they are not variables at all (no prior). Empty: the dataset's
  // FIX ids, or if it has none, the smallest id referenced by an edge.
  std::vector<std::int64_t> fixed;
};

struct BatchResult {
  Estimate2D poses;           // `initial` with every variable replaced by its final value
  double chi2_initial = 0.0;  // chi2G2o at `initial`
  double chi2 = 0.0;          // chi2G2o at `poses`
  int iterations = 0;         // linear solves (LM: including rejected trial steps)
  bool converged = false;     // true only if a convergence rule fired (see stop_reason)
  std::string stop_reason;
  double seconds = 0.0;  // wall-clock time of the whole call
};

// Minimises chi2G2o(d, .) starting from `initial`. Variables: every pose referenced by an edge,
// except the fixed ones. Throws std::invalid_argument if an edge references a pose missing from
// `initial` or has an information matrix that is not positive definite. Every connected component
// of the graph needs a fixed pose: otherwise GN fails (singular system) and LM cannot confirm a
// stop (see below), so such a run ends with converged = false.
//
// Gauss-Newton: solve H dx = -g, x <- x (+) dx, until norm(dx) < step_tolerance (converged), the
// relative change of chi2 <= gn_relative_decrease_tolerance (converged), a singular system or a
// non-finite chi2 (not converged), or max_iterations (not converged).
//
// Levenberg-Marquardt (seed, section 3.1): solve (H + lambda diag(H)) dm = -g; if norm(dm) <
// step_tolerance stop; else evaluate x (+) dm: accept if error_new <= error and lambda <=
// lambda_max (then lambda /= factor, and stop if error - error_new < error_decrease_tolerance),
// else lambda *= factor. `iterations` counts these solves (accepted or rejected). Differences from
// the seed, all on purpose:
//  - the initial error is the error at `initial` (the seed starts from a sentinel 1e7, which would
//    accept an increasing first step);
//  - after a rejection the next trial is solved with the linearisation at the current (accepted)
//    point (the seed reuses the Jacobian of the rejected point);
//  - once lambda > lambda_max the seed rejects every further step until maxIT; this solver stops at
//    once (same final estimate) with converged = false;
//  - the step rule and the decrease rule stop the run only once confirmed by the undamped
//    Gauss-Newton model at the current point (one extra factorisation, not counted in
//    `iterations`): its step norm < step_tolerance, or the error decrease it predicts,
//    sqrt(chi2) - sqrt(chi2 - g^T H^-1 g), < error_decrease_tolerance. An unconfirmed rule (a tiny
//    step only because lambda is large; a tiny decrease on a slow stretch) does not stop the run:
//    the trial step is evaluated as usual and the iteration goes on. So a run that ends in a
//    non-stationary point ends by lambda_max or max_iterations, with converged = false (and the
//    last unconfirmed rule quoted in stop_reason);
//  - the seed's loop checks maxIT before applying the step it just solved; here the step of the
//    last iteration is still evaluated.
// Gauss-Newton's relative-change rule is confirmed the same way (the GN model's step norm <
// step_tolerance or its predicted chi2 decrease <= gn_relative_decrease_tolerance * chi2); if not,
// GN continues.
BatchResult solveBatch2D(const Dataset2D& d, const Estimate2D& initial,
                         const BatchOptions& options = {});

// The retraction above: x (+) delta = (x + R(theta) delta_xy, wrap(theta + delta_theta)).
Pose2D retract2D(const Pose2D& x, const Eigen::Vector3d& delta);

// Analytic Jacobians of edgeErrorG2o(xi, xj, z) w.r.t. the perturbations xi (+) di and xj (+) dj at
// di = dj = 0 (the wrap of the angle is ignored: it is locally the identity).
void edgeJacobiansG2o(const Pose2D& xi, const Pose2D& xj, const Pose2D& z, Eigen::Matrix3d* jac_i,
                      Eigen::Matrix3d* jac_j);

}  // namespace lslam::sim
