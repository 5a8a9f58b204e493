#include "lslam/factors/pose_graph_2d.h"

#include <Eigen/Cholesky>
#include <cstring>

#include "lslam/factors/se2_factors.h"

namespace lslam {

PoseGraph2D::PoseGraph2D(const PoseGraph2DArrays& arrays) : a_(arrays) {
  LSLAM_ASSERT(a_.max_variables > 0 && a_.max_factors > 0);
  std::memset(a_.staged, 0, sizeof(std::uint32_t) * static_cast<std::size_t>(a_.max_variables));
}

void PoseGraph2D::beginUpdate() {
  LSLAM_ASSERT(!in_update_);
  in_update_ = true;
  if (++stamp_ == 0) {
    std::memset(a_.staged, 0, sizeof(std::uint32_t) * static_cast<std::size_t>(a_.max_variables));
    stamp_ = 1;
  }
  staged_count_ = 0;
}

Index PoseGraph2D::addVariable(const SE2& initial) {
  LSLAM_ASSERT(in_update_ && num_variables_ < a_.max_variables);
  const Index v = num_variables_++;
  a_.linearization[v] = initial;
  a_.first_entry[v] = kNoIndex;
  return v;
}

void PoseGraph2D::link(Index variable, Index factor) {
  const Index e = num_entries_++;
  a_.entry_factor[e] = factor;
  a_.next_entry[e] = a_.first_entry[variable];
  a_.first_entry[variable] = e;
}

Index PoseGraph2D::addPrior(Index variable, const SE2& z, const Mat3& information) {
  LSLAM_ASSERT(in_update_ && num_factors_ < a_.max_factors);
  LSLAM_ASSERT(variable >= 0 && variable < num_variables_);
  const Index f = num_factors_++;
  a_.kind[f] = FactorKind::PriorSE2;
  a_.first_variable[f] = variable;
  a_.second_variable[f] = kNoIndex;
  a_.measurement[f] = z;
  a_.information[f] = information;
  link(variable, f);
  return f;
}

Index PoseGraph2D::addBetween(Index from, Index to, const SE2& z, const Mat3& information) {
  LSLAM_ASSERT(in_update_ && num_factors_ < a_.max_factors);
  LSLAM_ASSERT(from >= 0 && from < num_variables_ && to >= 0 && to < num_variables_ && from != to);
  const Index f = num_factors_++;
  a_.kind[f] = FactorKind::BetweenSE2;
  a_.first_variable[f] = from;
  a_.second_variable[f] = to;
  a_.measurement[f] = z;
  a_.information[f] = information;
  link(from, f);
  link(to, f);
  return f;
}

void PoseGraph2D::relinearize(Index variable, const SE2& point) {
  LSLAM_ASSERT(in_update_ && variable >= 0 && variable < num_variables_);
  a_.staged_linearization[variable] = point;
  if (a_.staged[variable] != stamp_) a_.staged_list[staged_count_++] = variable;
  a_.staged[variable] = stamp_;
}

void PoseGraph2D::unstageRelinearization() {
  LSLAM_ASSERT(in_update_);
  for (Index i = 0; i < staged_count_; ++i) a_.staged[a_.staged_list[i]] = 0;  // stamps are >= 1
  staged_count_ = 0;
}

const SE2& PoseGraph2D::linearizationPoint(Index variable) const {
  return (in_update_ && a_.staged[variable] == stamp_) ? a_.staged_linearization[variable]
                                                       : a_.linearization[variable];
}

void PoseGraph2D::commit() {
  LSLAM_ASSERT(in_update_);
  for (Index i = 0; i < staged_count_; ++i) {
    const Index v = a_.staged_list[i];
    a_.linearization[v] = a_.staged_linearization[v];
  }
  committed_variables_ = num_variables_;
  committed_factors_ = num_factors_;
  committed_entries_ = num_entries_;
  in_update_ = false;
}

void PoseGraph2D::rollback() {
  LSLAM_ASSERT(in_update_);
  // Unlink the added factors newest first: each was pushed at the head of its variables' lists.
  for (Index f = num_factors_ - 1; f >= committed_factors_; --f) {
    const Index second = a_.second_variable[f];
    if (second != kNoIndex) a_.first_entry[second] = a_.next_entry[a_.first_entry[second]];
    const Index first = a_.first_variable[f];
    a_.first_entry[first] = a_.next_entry[a_.first_entry[first]];
  }
  num_variables_ = committed_variables_;
  num_factors_ = committed_factors_;
  num_entries_ = committed_entries_;
  in_update_ = false;
}

double PoseGraph2D::factorChi2(Index factor) const {
  Vec3 e;
  if (a_.kind[factor] == FactorKind::PriorSE2) {
    e = priorErrorSE2(linearizationPoint(a_.first_variable[factor]), a_.measurement[factor]);
  } else {
    e = betweenErrorSE2(linearizationPoint(a_.first_variable[factor]),
                        linearizationPoint(a_.second_variable[factor]), a_.measurement[factor]);
  }
  return e.dot(a_.information[factor] * e);
}

Index PoseGraph2D::whitenedRows(Index factor, const Index* position, Index* positions,
                                Mat3* rows_transposed, Vec3* rhs) const {
  // Omega = L L^T, so R = L^T; the information was checked positive definite on insert.
  const Eigen::LLT<Mat3> llt(a_.information[factor]);
  const Mat3 l = llt.matrixL();
  const Index first = a_.first_variable[factor];
  Vec3 e;
  if (a_.kind[factor] == FactorKind::PriorSE2) {
    Mat3 j;
    e = priorErrorSE2(linearizationPoint(first), a_.measurement[factor], &j);
    positions[0] = position[first];
    rows_transposed[0] = j.transpose() * l;
    *rhs = -(l.transpose() * e);
    return 1;
  }
  const Index second = a_.second_variable[factor];
  Mat3 j_first;
  Mat3 j_second;
  e = betweenErrorSE2(linearizationPoint(first), linearizationPoint(second), a_.measurement[factor],
                      &j_first, &j_second);
  positions[0] = position[first];
  positions[1] = position[second];
  rows_transposed[0] = j_first.transpose() * l;
  rows_transposed[1] = j_second.transpose() * l;
  *rhs = -(l.transpose() * e);
  return 2;
}

void PoseGraph2D::visitNeighbours(Index variable, NeighbourVisitor& visitor) const {
  for (Index e = a_.first_entry[variable]; e != kNoIndex; e = a_.next_entry[e]) {
    const Index f = a_.entry_factor[e];
    if (a_.kind[f] != FactorKind::BetweenSE2) continue;
    visitor.visit(otherVariable(f, variable));
  }
}

void PoseGraph2D::addContribution(Index f, Index variable, const Index* position, bool committed,
                                  double sign, ColumnAccumulator<3>& acc) const {
  auto point = [&](Index v) -> const SE2& {
    return committed ? a_.linearization[v] : linearizationPoint(v);
  };
  const Mat3 omega = sign * a_.information[f];
  if (a_.kind[f] == FactorKind::PriorSE2) {
    Mat3 j;
    const Vec3 err = priorErrorSE2(point(variable), a_.measurement[f], &j);
    const Mat3 jt_omega = j.transpose() * omega;
    acc.addDiagonal(jt_omega * j);
    acc.addEta(-(jt_omega * err));
    return;
  }
  const Index i = a_.first_variable[f];
  const Index k = a_.second_variable[f];
  Mat3 j_i;
  Mat3 j_k;
  const Vec3 err = betweenErrorSE2(point(i), point(k), a_.measurement[f], &j_i, &j_k);
  const bool is_first = (i == variable);
  const Mat3& j_self = is_first ? j_i : j_k;
  const Mat3& j_other = is_first ? j_k : j_i;
  const Index other = is_first ? k : i;
  const Mat3 omega_j_self = omega * j_self;
  acc.addDiagonal(j_self.transpose() * omega_j_self);
  acc.addEta(-(j_self.transpose() * (omega * err)));
  // Lambda(other, self) = J_other^T Omega J_self, kept only below the diagonal.
  if (position[other] > position[variable]) {
    acc.addBelow(position[other], j_other.transpose() * omega_j_self);
  }
}

void PoseGraph2D::assembleColumn(Index variable, const Index* position, ColumnAccumulator<3>& acc,
                                 LaterDiagonals<3>& later) const {
  for (Index e = a_.first_entry[variable]; e != kNoIndex; e = a_.next_entry[e]) {
    const Index f = a_.entry_factor[e];
    if (a_.kind[f] == FactorKind::PriorSE2) {
      addContribution(f, variable, position, false, 1.0, acc);
      continue;
    }
    const Index i = a_.first_variable[f];
    const Index k = a_.second_variable[f];
    const Index other = otherVariable(f, variable);
    if (position[other] < position[variable]) continue;  // assembled with the earlier column
    Mat3 j_i;
    Mat3 j_k;
    const Vec3 err = betweenErrorSE2(linearizationPoint(i), linearizationPoint(k),
                                     a_.measurement[f], &j_i, &j_k);
    const Mat3& j_self = i == variable ? j_i : j_k;
    const Mat3& j_other = i == variable ? j_k : j_i;
    const Mat3& omega = a_.information[f];
    const Mat3 omega_j_self = omega * j_self;
    const Mat3 omega_j_other = omega * j_other;
    const Vec3 omega_err = omega * err;
    acc.addDiagonal(j_self.transpose() * omega_j_self);
    acc.addEta(-(j_self.transpose() * omega_err));
    acc.addBelow(position[other], j_other.transpose() * omega_j_self);
    later.addDiagonal(position[other], j_other.transpose() * omega_j_other);
    later.addEta(position[other], -(j_other.transpose() * omega_err));
  }
}

void PoseGraph2D::assembleColumnChange(Index variable, const Index* position,
                                       ColumnAccumulator<3>& acc) const {
  const bool self_moved = isStaged(variable);
  for (Index e = a_.first_entry[variable]; e != kNoIndex; e = a_.next_entry[e]) {
    const Index f = a_.entry_factor[e];
    const bool is_new = f >= committed_factors_;
    if (!is_new) {
      const Index other = otherVariable(f, variable);
      if (!self_moved && (other == kNoIndex || !isStaged(other))) continue;
      addContribution(f, variable, position, true, -1.0, acc);
    }
    addContribution(f, variable, position, false, 1.0, acc);
  }
}

}  // namespace lslam
