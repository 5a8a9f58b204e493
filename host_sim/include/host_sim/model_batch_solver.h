#pragma once
// The independent batch reference solver for every model: SE2/SE3 poses, Point2/Point3 landmarks
// and every FactorKind of model_dataset.h, minimising chi2(d, .) of model_chi2.h in the dataset's
// convention (G2o or Isam). Host-only; shares no code with firmware_lib (no lslam/ header).
// Gauss-Newton or Levenberg-Marquardt with exactly the stopping rules of solveBatch2D (the same
// loop, batch_solver.h), sparse normal equations, COLAMD ordering on the variable-block structure
// of the Jacobian, Eigen::SimplicialLLT.
//
// Variables and retractions (x (+) d, d in the tangent space, size 3 / 2 / 6 / 3):
//   SE2    (x, y, theta) (+) d = (t + R(theta) d_xy, wrap(theta + d_theta))   (as retract2D)
//   Point2 l (+) d = l + d
//   SE3    (t, q) (+) d = (t + R(q) d_t, normalise(q * Exp(d_w))), d = (d_t, d_w): the pose
//          composed on the right with the increment read as a pose (body-frame translation
//          d_t, rotation Exp(d_w) = the rotation by |d_w| about d_w); agrees with X Exp(d) of
//          SE(3) to first order, so optimum and chi2 are the same.
//   Point3 l (+) d = l + d
// Jacobians: central differences of the whitened error along the retraction, step 1e-5 per
// tangent coordinate (an angular error component is differenced wrapped). No analytic Jacobians:
// the error functions of model_chi2.h are the only model of each factor.
//
// Whitening: Omega = R^T R from an LLT of the symmetrised information (per factor); a factor whose
// information is not positive definite is rejected (std::invalid_argument).
//
// Gauge: options.fixed (pose ids), else the dataset's FIX keys that are poses, else the pose with
// the smallest id referenced by a factor; fixed poses are not variables at all (no prior).
// Landmarks are never fixed (a FIX key naming a landmark is ignored).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "host_sim/batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"

namespace lslam::sim {

struct ModelBatchResult {
  ModelEstimate values;       // `initial` with every variable replaced by its final value
  double chi2_initial = 0.0;  // chi2(d, initial)
  double chi2 = 0.0;          // chi2(d, values)
  int iterations = 0;         // linear solves (LM: including rejected trial steps)
  bool converged = false;     // true only if a convergence rule fired (see stop_reason)
  std::string stop_reason;
  std::vector<VariableKey> fixed;  // the gauge used (fixed poses referenced by a factor)
  double seconds = 0.0;            // wall-clock time of the whole call
};

// Minimises chi2(d, .) from `initial` (for instance initialEstimate(d)). Variables: every key
// referenced by a factor, except the fixed poses. Throws std::invalid_argument if a variable has
// no value in `initial` or one of the wrong size, if a key is used as two kinds, or if a factor's
// information is not positive definite. Stopping rules, BatchOptions and the meaning of converged
// as for solveBatch2D (batch_solver.h).
ModelBatchResult solveModelBatch(const ModelDataset& d, const ModelEstimate& initial,
                                 const BatchOptions& options = {});

// The retraction above, on a value of `kind` (parameterCount entries; delta: tangentDimension).
Eigen::VectorXd retractModel(VariableKind kind, const Eigen::VectorXd& x,
                             const Eigen::VectorXd& delta);

}  // namespace lslam::sim
