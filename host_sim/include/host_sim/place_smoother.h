#pragma once
// The trajectory of a run past the compact map's capacity, smoothed backward along its odometry
// (Rauch-Tung-Striebel on the group, first order). Host-only.
//
// Past its capacity CompactPoseGraph keeps each pose as a place: an offset from a node with the
// offset's covariance, a filter's estimate (the odometry and the measurements up to that step).
// A smoother also uses what came after: the odometry to the next pose ties each pose to the next
// one's smoothed estimate. Backward from the last step, with x_i the filtered pose (its node's
// final estimate composed with its offset), P_i its covariance, u and Q the odometry to the next
// pose and its covariance (right perturbations throughout):
//   predicted x_i u, with covariance P' = J P_i J^T + Q (J = Ad(u^-1), composition's Jacobian),
//   gain G = P_i J^T P'^-1,
//   smoothed x_i^s = x_i Exp(G Log((x_i u)^-1 x_{i+1}^s)).
// A node (covariance 0) is the map's own smoothed estimate and stays.
#include <cstddef>
#include <vector>

#include "lslam/eigen.h"

namespace lslam::sim {

template <class Pose>
struct FilteredPlace {
  using Matrix = Eigen::Matrix<double, Pose::kDof, Pose::kDof>;
  Pose estimate;                       // x_i: its node's final estimate composed with its offset
  Matrix covariance = Matrix::Zero();  // P_i: the offset's (0: a node)
  Pose odometry;                       // u: the next pose seen from this one (not the last's)
  Matrix odometry_covariance = Matrix::Zero();  // Q, in the tangent
};

// The smoothed poses, in the order of `places` (consecutive steps).
template <class Pose>
std::vector<Pose> smoothPlaces(const std::vector<FilteredPlace<Pose>>& places) {
  using Matrix = typename FilteredPlace<Pose>::Matrix;
  std::vector<Pose> smoothed(places.size());
  for (std::size_t k = places.size(); k-- > 0;) {
    const FilteredPlace<Pose>& p = places[k];
    if (k + 1 == places.size() || p.covariance.isZero(0.0)) {
      smoothed[k] = p.estimate;
      continue;
    }
    Matrix j;
    const Pose predicted = p.estimate.compose(p.odometry, &j);
    const Matrix predicted_covariance = j * p.covariance * j.transpose() + p.odometry_covariance;
    const Matrix gain_transposed =
        predicted_covariance.ldlt().solve(j * p.covariance.transpose());  // (P J^T P'^-1)^T
    smoothed[k] = p.estimate.retract(gain_transposed.transpose() *
                                     predicted.localCoordinates(smoothed[k + 1]));
  }
  return smoothed;
}

}  // namespace lslam::sim
