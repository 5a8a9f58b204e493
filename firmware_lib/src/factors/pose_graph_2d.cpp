#include "lslam/factors/pose_graph_2d.h"

#include <Eigen/Cholesky>
#include <cstring>

#include "lslam/factors/information.h"
#include "lslam/factors/se2_factors.h"

namespace lslam {

PoseGraph2D::PoseGraph2D(const PoseGraph2DArrays& arrays, bool cache_linearizations)
    : a_(arrays),
      cache_(cache_linearizations && a_.linearized != nullptr && a_.linearized_epoch != nullptr) {
  LSLAM_ASSERT(a_.max_variables > 0 && a_.max_factors > 0 && a_.point_epoch != nullptr);
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
  a_.point_epoch[v] = epoch_;
  a_.first_entry[v] = kNoIndex;
  return v;
}

void PoseGraph2D::link(Index variable, Index factor) {
  const Index e = num_entries_++;
  a_.entry_factor[e] = factor;
  a_.next_entry[e] = a_.first_entry[variable];
  a_.first_entry[variable] = e;
}

// The factor's record, its information stored symmetric; the caller links it to its variables.
Index PoseGraph2D::appendFactor(FactorKind kind, Index first, Index second, const SE2& z,
                                const Mat3& information) {
  LSLAM_ASSERT(in_update_ && num_factors_ < a_.max_factors);
  const Index f = num_factors_++;
  a_.kind[f] = kind;
  a_.first_variable[f] = first;
  a_.second_variable[f] = second;
  a_.measurement[f] = z;
  a_.information[f] = information;
  symmetrize(a_.information[f]);
  return f;
}

Index PoseGraph2D::addPrior(Index variable, const SE2& z, const Mat3& information) {
  LSLAM_ASSERT(variable >= 0 && variable < num_variables_);
  const Index f = appendFactor(FactorKind::PriorSE2, variable, kNoIndex, z, information);
  link(variable, f);
  return f;
}

Index PoseGraph2D::addBetween(Index from, Index to, const SE2& z, const Mat3& information) {
  LSLAM_ASSERT(from >= 0 && from < num_variables_ && to >= 0 && to < num_variables_ && from != to);
  const Index f = appendFactor(FactorKind::BetweenSE2, from, to, z, information);
  if (cache_) a_.linearized_epoch[f] = 0;  // nothing cached (may hold a rolled-back factor's)
  link(from, f);
  link(to, f);
  return f;
}

void PoseGraph2D::disablePrior(Index factor) {
  LSLAM_ASSERT(in_update_ && disabled_ == kNoIndex && factor >= 0 && factor < committed_factors_ &&
               a_.kind[factor] == FactorKind::PriorSE2);
  disabled_ = factor;
  disabled_information_ = a_.information[factor];
  a_.information[factor].setZero();
}

void PoseGraph2D::relinearize(Index variable, const SE2& point) {
  LSLAM_ASSERT(in_update_ && variable >= 0 && variable < num_variables_);
  a_.staged_linearization[variable] = point;
  if (a_.staged[variable] != stamp_) a_.staged_list[staged_count_++] = variable;
  a_.staged[variable] = stamp_;
}

void PoseGraph2D::unstageRelinearization() {
  LSLAM_ASSERT(in_update_);
  forgetStagedLinearizations();
  for (Index i = 0; i < staged_count_; ++i) a_.staged[a_.staged_list[i]] = 0;  // stamps are >= 1
  staged_count_ = 0;
}

const SE2& PoseGraph2D::linearizationPoint(Index variable) const {
  return (in_update_ && a_.staged[variable] == stamp_) ? a_.staged_linearization[variable]
                                                       : a_.linearization[variable];
}

void PoseGraph2D::commit() {
  LSLAM_ASSERT(in_update_);
  if (staged_count_ > 0) advanceEpoch();
  for (Index i = 0; i < staged_count_; ++i) {
    const Index v = a_.staged_list[i];
    a_.linearization[v] = a_.staged_linearization[v];
    a_.point_epoch[v] = epoch_;
  }
  committed_variables_ = num_variables_;
  committed_factors_ = num_factors_;
  committed_entries_ = num_entries_;
  disabled_ = kNoIndex;
  in_update_ = false;
}

// Moved points take the next epoch, so that every linearization cached before stops matching
// them. On wrapping, every cached linearization is forgotten and every point restarts at epoch 1.
void PoseGraph2D::advanceEpoch() {
  if (++epoch_ != 0) return;
  epoch_ = 1;
  for (Index f = 0; cache_ && f < num_factors_; ++f) a_.linearized_epoch[f] = 0;
  for (Index v = 0; v < num_variables_; ++v) a_.point_epoch[v] = epoch_;
}

// The staged points are dropped: whatever the cache kept at them (stamped epoch_ + 1) must not
// match again, so the staged variables move to an epoch past that stamp.
void PoseGraph2D::forgetStagedLinearizations() {
  if (staged_count_ == 0) return;
  advanceEpoch();
  advanceEpoch();
  for (Index i = 0; i < staged_count_; ++i) a_.point_epoch[a_.staged_list[i]] = epoch_;
}

void PoseGraph2D::rollback() {
  LSLAM_ASSERT(in_update_);
  forgetStagedLinearizations();
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
  if (disabled_ != kNoIndex) a_.information[disabled_] = disabled_information_;
  disabled_ = kNoIndex;
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

// One expression for every use, so that a cached linearization and a fresh one are the same bits.
void PoseGraph2D::computeLinearizedBetween(Index f, const SE2& first, const SE2& second,
                                           LinearizedBetween& out) const {
  Mat3 j_first;
  Mat3 j_second;
  const Vec3 err = betweenErrorSE2(first, second, a_.measurement[f], &j_first, &j_second);
  // The Jacobians' zeros and ones are known (se2_factors.cpp): J_second = [R 0; 0 1] and
  // J_first = [M p; 0 -1] with 2 x 2 blocks R, M. The products skip them: 91 multiplications
  // instead of the general products' 162, for every factor whose points moved at a full
  // refactorization (on a large graph, thousands). The terms dropped are exact zeros and the unit
  // factors exact, so skipping them changes no rounding.
  const Mat3& omega = a_.information[f];
  const Vec3 o0 = omega.col(0);
  const Vec3 o1 = omega.col(1);
  const Vec3 o2 = omega.col(2);
  // Omega J: a column k < 2 mixes Omega's first two columns by the block's column k.
  Mat3 o_first;
  o_first.col(0) = o0 * j_first(0, 0) + o1 * j_first(1, 0);
  o_first.col(1) = o0 * j_first(0, 1) + o1 * j_first(1, 1);
  o_first.col(2) = o0 * j_first(0, 2) + o1 * j_first(1, 2) - o2;
  Mat3 o_second;
  o_second.col(0) = o0 * j_second(0, 0) + o1 * j_second(1, 0);
  o_second.col(1) = o0 * j_second(0, 1) + o1 * j_second(1, 1);
  o_second.col(2) = o2;
  const Vec3 o_err = omega * err;
  // J^T (Omega J): row i < 2 mixes the first two rows by the block's column i.
  for (int i = 0; i < 2; ++i) {
    out.first_first.row(i) = j_first(0, i) * o_first.row(0) + j_first(1, i) * o_first.row(1);
    out.second_second.row(i) = j_second(0, i) * o_second.row(0) + j_second(1, i) * o_second.row(1);
    out.second_first.row(i) = j_second(0, i) * o_first.row(0) + j_second(1, i) * o_first.row(1);
    out.eta_first(i) = -(j_first(0, i) * o_err(0) + j_first(1, i) * o_err(1));
    out.eta_second(i) = -(j_second(0, i) * o_err(0) + j_second(1, i) * o_err(1));
  }
  out.first_first.row(2) =
      j_first(0, 2) * o_first.row(0) + j_first(1, 2) * o_first.row(1) - o_first.row(2);
  out.second_second.row(2) = o_second.row(2);
  out.second_first.row(2) = o_first.row(2);
  out.eta_first(2) = -(j_first(0, 2) * o_err(0) + j_first(1, 2) * o_err(1) - o_err(2));
  out.eta_second(2) = -o_err(2);
}

// Linearizing dominates assembling a column (three sines and cosines and seven 3x3 products per
// factor), and a full refactorization assembles every factor, most of them at the same points as
// the last one: the cache keeps each factor's linearization until one of its points moves. An entry
// is stamped with the epoch it was computed in, and valid while no point of its factor moved since
// (its variables' point_epoch). A full refactorization also keeps what it computes at staged
// points, stamped with the epoch its commit will open (those points then become the committed
// ones); a rollback, or unstaging, moves the staged variables' point_epoch past that stamp. So an
// entry that is used always holds what would be computed afresh, and every result is the same bits
// with or without the cache.
const LinearizedBetween& PoseGraph2D::linearizedBetween(Index f, bool committed, bool keep_staged,
                                                        LinearizedBetween& scratch) const {
  const Index first = a_.first_variable[f];
  const Index second = a_.second_variable[f];
  if (!cache_) {
    computeLinearizedBetween(f, pointOf(first, committed), pointOf(second, committed), scratch);
    return scratch;
  }
  const std::uint32_t at = a_.linearized_epoch[f];
  LinearizedBetween& entry = a_.linearized[f];
  if (!committed && (isStaged(first) || isStaged(second))) {
    const std::uint32_t next = epoch_ + 1;
    if (next == 0 || !keep_staged) {  // (at the wrap, nothing is kept ahead)
      computeLinearizedBetween(f, linearizationPoint(first), linearizationPoint(second), scratch);
      return scratch;
    }
    if (at != next) {
      computeLinearizedBetween(f, linearizationPoint(first), linearizationPoint(second), entry);
      a_.linearized_epoch[f] = next;
    }
    return entry;
  }
  if (at > epoch_ || at < a_.point_epoch[first] || at < a_.point_epoch[second]) {
    computeLinearizedBetween(f, a_.linearization[first], a_.linearization[second], entry);
    a_.linearized_epoch[f] = epoch_;
  }
  return entry;
}

void PoseGraph2D::addContribution(Index f, Index variable, const Index* position, bool committed,
                                  bool subtract, ColumnAccumulator<3>& acc) const {
  if (a_.kind[f] == FactorKind::PriorSE2) {
    const SE2& point = pointOf(variable, committed);
    const Mat3 omega = subtract ? Mat3(-a_.information[f]) : a_.information[f];
    Mat3 j;
    const Vec3 err = priorErrorSE2(point, a_.measurement[f], &j);
    const Mat3 jt_omega = j.transpose() * omega;
    acc.addDiagonal(jt_omega * j);
    acc.addEta(-(jt_omega * err));
    return;
  }
  LinearizedBetween scratch;
  const LinearizedBetween& lin = linearizedBetween(f, committed, false, scratch);
  const bool is_first = a_.first_variable[f] == variable;
  const Index other = otherVariable(f, variable);
  // Negation is exact: subtracting a share is adding its negation, bit for bit.
  const double sign = subtract ? -1.0 : 1.0;
  acc.addDiagonal(sign * (is_first ? lin.first_first : lin.second_second));
  acc.addEta(sign * (is_first ? lin.eta_first : lin.eta_second));
  // Lambda(other, self), kept only below the diagonal.
  if (position[other] > position[variable]) {
    acc.addBelow(position[other], is_first ? Mat3(sign * lin.second_first)
                                           : Mat3(sign * lin.second_first.transpose()));
  }
}

void PoseGraph2D::assembleColumn(Index variable, const Index* position, ColumnAccumulator<3>& acc,
                                 LaterDiagonals<3>& later) const {
  for (Index e = a_.first_entry[variable]; e != kNoIndex; e = a_.next_entry[e]) {
    const Index f = a_.entry_factor[e];
    if (a_.kind[f] == FactorKind::PriorSE2) {
      addContribution(f, variable, position, false, false, acc);
      continue;
    }
    const Index other = otherVariable(f, variable);
    if (position[other] < position[variable]) continue;  // assembled with the earlier column
    LinearizedBetween scratch;
    const LinearizedBetween& lin = linearizedBetween(f, false, true, scratch);
    if (a_.first_variable[f] == variable) {
      acc.addDiagonal(lin.first_first);
      acc.addEta(lin.eta_first);
      acc.addBelow(position[other], lin.second_first);
      later.addDiagonal(position[other], lin.second_second);
      later.addEta(position[other], lin.eta_second);
    } else {
      acc.addDiagonal(lin.second_second);
      acc.addEta(lin.eta_second);
      acc.addBelow(position[other], lin.second_first.transpose());
      later.addDiagonal(position[other], lin.first_first);
      later.addEta(position[other], lin.eta_first);
    }
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
      addContribution(f, variable, position, true, true, acc);
    }
    addContribution(f, variable, position, false, false, acc);
  }
}

}  // namespace lslam
