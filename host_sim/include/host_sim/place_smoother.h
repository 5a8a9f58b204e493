#pragma once
// The trajectory of a run past the compact map's capacity, estimated after the run from what the
// robot logged: the map's final nodes, each pose's odometry and the loop closures that saw it,
// filtered forward and smoothed backward along the odometry (Rauch-Tung-Striebel on the group,
// first order, right perturbations throughout). Host-only.
//
// Past its capacity CompactPoseGraph keeps each pose as a place, a filter's estimate made with the
// map of its time. Here every pose is estimated again against the final map:
//   forward:  x_k = x_{k-1} u_k, P_k = J P_{k-1} J^T + Q_k (J = Ad(u_k^-1)); each loop closure to
//             an earlier pose s, y = x_s z with covariance J_z P_s J_z^T + R (J_z = Ad(z^-1)),
//             updates x_k as a Kalman filter does, exactly so from a node (the map's nodes are
//             exact); from a pose past the capacity the correlation of x_s and x_k (the odometry
//             between them) is left out, which makes the update overconfident; then the caller's
//             other measurements (landmark observations against the final landmarks);
//   backward: G = P_k J^T P'^-1 (P' the prediction's covariance), x_k^s = x_k Exp(G Log((x_k
//             u)^-1 x_{k+1}^s)).
// A loop closure between two poses past the capacity ties them both ways, which one forward pass
// cannot: a second pass reads the first pass's smoothed estimates, and each pose also takes the
// closures that saw it later (y = x_t^s z^-1). That reuse counts some information twice (the two
// ends have each seen the other), so the estimate improves and the covariances would be too
// small: none is reported. A node (`known`) is the map's own estimate and stays.
#include <cstddef>
#include <vector>

#include "lslam/eigen.h"

namespace lslam::sim {

template <class Pose>
struct LoggedPose {
  using Matrix = Eigen::Matrix<double, Pose::kDof, Pose::kDof>;
  // A loop closure: this pose seen from the earlier pose `from` (its index in the log) as
  // `measurement`, with the measurement's covariance in the tangent.
  struct Closure {
    std::size_t from = 0;
    Pose measurement;
    Matrix covariance = Matrix::Zero();
  };
  bool known = false;                  // a node: `estimate` is the map's
  Pose estimate;                       // a node's; the first pose's prior when it is not a node
  Matrix covariance = Matrix::Zero();  // the first pose's prior (unused otherwise)
  Pose odometry;                       // this pose seen from the previous one (not the first's)
  Matrix odometry_covariance = Matrix::Zero();
  std::vector<Closure> closures;
};

namespace detail {

// Past this ratio of an LDLT's largest pivot to its smallest (a lower bound on the condition
// number) a gain solved from it is mostly rounding, which the backward pass carries from pose to
// pose, growing (a heading all but unknown: variances of 1e16 next to 1e-4). It trades an update
// or a smoothing step skipped on such a covariance against a gain that would be noise.
constexpr double kMaxGainCondition = 1e12;

template <class Ldlt>
bool wellConditioned(const Ldlt& ldlt) {
  const auto pivots = ldlt.vectorD().cwiseAbs();
  return ldlt.info() == Eigen::Success && pivots.minCoeff() > 0.0 &&
         pivots.maxCoeff() <= kMaxGainCondition * pivots.minCoeff();
}

// x, P updated by a measurement y of x itself with covariance r (the information-weighted mean in
// the tangent at x). An update double precision cannot resolve (a covariance that overflowed, or
// P + R too ill-conditioned for its gain) leaves x and P as they were, as the robot's place did
// (CompactPoseGraph).
template <class Pose>
void updateWithPose(Pose& x, typename LoggedPose<Pose>::Matrix& p, const Pose& y,
                    const typename LoggedPose<Pose>::Matrix& r) {
  using Matrix = typename LoggedPose<Pose>::Matrix;
  const auto sum = (p + r).transpose().ldlt();
  if (!wellConditioned(sum)) return;
  const Matrix gain = sum.solve(p.transpose()).transpose();  // P (P + R)^-1
  const auto step = (gain * x.localCoordinates(y)).eval();
  Matrix updated = (Matrix::Identity() - gain) * p;
  updated = (0.5 * (updated + updated.transpose())).eval();
  if (!step.allFinite() || !updated.allFinite()) return;
  x = x.retract(step);
  p = updated;
}

template <class Pose>
struct Pass {
  std::vector<Pose> smoothed;
  std::vector<typename LoggedPose<Pose>::Matrix> filtered_covariance;
};

// One forward pass and the backward pass over the log; `earlier` (empty in the first pass) is the
// previous pass, whose smoothed estimates the second pass reads for closures both ways.
template <class Pose, class Correct>
Pass<Pose> filterAndSmooth(const std::vector<LoggedPose<Pose>>& log, const Pass<Pose>& earlier,
                           const std::vector<std::vector<std::size_t>>& seen_later,
                           Correct& correct) {
  using Matrix = typename LoggedPose<Pose>::Matrix;
  const std::size_t n = log.size();
  const bool second = !earlier.smoothed.empty();
  std::vector<Pose> x(n);
  Pass<Pose> out;
  std::vector<Matrix>& p = out.filtered_covariance;
  p.assign(n, Matrix::Zero());
  for (std::size_t k = 0; k < n; ++k) {
    const LoggedPose<Pose>& l = log[k];
    if (l.known || k == 0) {
      x[k] = l.estimate;
      p[k] = l.known ? Matrix::Zero() : l.covariance;
      if (l.known) continue;
    } else {
      Matrix j;
      x[k] = x[k - 1].compose(l.odometry, &j);
      p[k] = j * p[k - 1] * j.transpose() + l.odometry_covariance;
    }
    for (const auto& c : l.closures) {
      const Pose& from = second && !log[c.from].known ? earlier.smoothed[c.from] : x[c.from];
      Matrix j;
      const Pose seen = from.compose(c.measurement, &j);
      updateWithPose(x[k], p[k], seen, j * p[c.from] * j.transpose() + c.covariance);
    }
    if (second) {
      for (const std::size_t t : seen_later[k]) {
        for (const auto& c : log[t].closures) {
          if (c.from != k) continue;
          // y = x_t z^-1: x_t's perturbation maps through Ad(z), z's through -Ad(z) (the
          // inverse's Jacobian, j), so the covariance is j (P_t + R) j^T.
          Matrix j;
          const Pose back = c.measurement.inverse(&j);
          const Matrix p_t = log[t].known ? Matrix::Zero() : earlier.filtered_covariance[t];
          updateWithPose(x[k], p[k], earlier.smoothed[t].compose(back),
                         j * (p_t + c.covariance) * j.transpose());
        }
      }
    }
    correct(k, x[k], p[k]);
  }
  out.smoothed.resize(n);
  for (std::size_t k = n; k-- > 0;) {
    if (k + 1 == n || log[k].known) {
      out.smoothed[k] = x[k];
      continue;
    }
    Matrix j;
    const Pose predicted = x[k].compose(log[k + 1].odometry, &j);
    const Matrix predicted_covariance = j * p[k] * j.transpose() + log[k + 1].odometry_covariance;
    const auto predicted_ldlt = predicted_covariance.ldlt();
    const Matrix gain_transposed = predicted_ldlt.solve(j * p[k].transpose());  // (P J^T P'^-1)^T
    const auto step =
        (gain_transposed.transpose() * predicted.localCoordinates(out.smoothed[k + 1])).eval();
    // (A gain that overflowed, or that P' cannot resolve, leaves the filtered estimate.)
    const bool smooth = wellConditioned(predicted_ldlt) && step.allFinite();
    out.smoothed[k] = smooth ? x[k].retract(step) : x[k];
  }
  return out;
}

}  // namespace detail

// The smoothed poses of the log, in its order (consecutive poses). correct(k, x, P) applies pose
// k's other measurements to its estimate x and covariance P (a no-op for a pose graph).
template <class Pose, class Correct>
std::vector<Pose> smoothTrajectory(const std::vector<LoggedPose<Pose>>& log, Correct correct) {
  std::vector<std::vector<std::size_t>> seen_later(log.size());
  for (std::size_t t = 0; t < log.size(); ++t) {
    for (const auto& c : log[t].closures) {
      if (seen_later[c.from].empty() || seen_later[c.from].back() != t) {
        seen_later[c.from].push_back(t);
      }
    }
  }
  const detail::Pass<Pose> first = detail::filterAndSmooth(log, {}, seen_later, correct);
  return detail::filterAndSmooth(log, first, seen_later, correct).smoothed;
}

}  // namespace lslam::sim
