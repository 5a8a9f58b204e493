// PoseGraph2D as the factorization's source of Lambda and eta: the assembly that linearizes each
// factor once (adding to the later variable's diagonal and eta ahead of time) against a dense
// J^T Omega J built from central-difference Jacobians, in random column orders; and the whitened
// rows of the row update against host_sim's analytic Jacobians, for an information matrix
// symmetric only to rounding.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "host_sim/batch_solver.h"
#include "host_sim/chi2.h"
#include "lslam/factors/information.h"
#include "lslam/factors/pose_graph_2d.h"
#include "lslam/factors/se2_factors.h"
#include "numerical_diff.h"

using namespace lslam;
using namespace lslam::test;

namespace {

constexpr int kVariables = 14;
constexpr int kFactors = 40;
constexpr int kCases = 60;
constexpr unsigned kSeed = 5521u;

Mat3 randomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Mat3 a;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a(r, c) = u(rng);
  return a * a.transpose() + Mat3::Identity();
}

struct Reference {
  Eigen::MatrixXd lambda = Eigen::MatrixXd::Zero(3 * kVariables, 3 * kVariables);
  Eigen::VectorXd eta = Eigen::VectorXd::Zero(3 * kVariables);
  std::vector<std::set<Index>> neighbours = std::vector<std::set<Index>>(kVariables);
};

// Adds J^T Omega J and -J^T Omega e of one factor, J by central differences.
void addReference(Reference& ref, Index i, Index j, const SE2& xi, const SE2& xj, const SE2& z,
                  const Mat3& omega) {
  const Vec3 e = betweenErrorSE2(xi, xj, z);
  Eigen::Matrix<double, 3, 6> jac;
  jac.leftCols<3>() =
      numericalJacobianSE2([&](const SE2& x) -> Vec3 { return betweenErrorSE2(x, xj, z); }, xi);
  jac.rightCols<3>() =
      numericalJacobianSE2([&](const SE2& x) -> Vec3 { return betweenErrorSE2(xi, x, z); }, xj);
  const Eigen::Matrix<double, 6, 6> h = jac.transpose() * omega * jac;
  const Eigen::Matrix<double, 6, 1> g = -(jac.transpose() * omega * e);
  const Index idx[2] = {i, j};
  for (int p = 0; p < 2; ++p) {
    ref.eta.segment<3>(3 * idx[p]) += g.segment<3>(3 * p);
    for (int q = 0; q < 2; ++q)
      ref.lambda.block<3, 3>(3 * idx[p], 3 * idx[q]) += h.block<3, 3>(3 * p, 3 * q);
  }
  ref.neighbours[i].insert(j);
  ref.neighbours[j].insert(i);
}

}  // namespace

TEST_CASE("assembleColumn linearizes each factor once and reproduces J^T Omega J and eta") {
  std::mt19937 rng(kSeed);
  auto storage = std::make_unique<StaticPoseGraph2DStorage<kVariables, kFactors + 1>>();
  for (int c = 0; c < kCases; ++c) {
    CAPTURE(c);
    PoseGraph2D graph(storage->arrays());
    Reference ref;
    graph.beginUpdate();
    std::vector<SE2> poses;
    for (int v = 0; v < kVariables; ++v) {
      poses.push_back(randomPose(rng, c + v));
      graph.addVariable(poses.back());
    }
    const SE2 prior_z = randomPose(rng, c);
    const Mat3 prior_omega = randomInformation(rng);
    graph.addPrior(0, prior_z, prior_omega);
    {  // the prior's share, its Jacobian by central differences too
      const Mat3 jac = numericalJacobianSE2(
          [&](const SE2& x) -> Vec3 { return priorErrorSE2(x, prior_z); }, poses[0]);
      ref.lambda.topLeftCorner<3, 3>() += jac.transpose() * prior_omega * jac;
      ref.eta.head<3>() -= jac.transpose() * prior_omega * priorErrorSE2(poses[0], prior_z);
    }
    // A chain and random loops; measurements near the truth keep every angle error off its cut.
    std::uniform_int_distribution<Index> pick(0, kVariables - 1);
    for (int f = 0; f < kFactors; ++f) {
      Index i = f < kVariables - 1 ? f : pick(rng);
      Index j = f < kVariables - 1 ? f + 1 : pick(rng);
      if (i == j) j = (i + 1) % kVariables;
      if (f % 3 == 0) std::swap(i, j);  // either variable may come first in the factor
      const SE2 z = fromMatrix(toMatrix(poses[i]).inverse() * toMatrix(poses[j]) *
                               expMatrix(0.2 * randomTangent(rng, f)));
      const Mat3 omega = randomInformation(rng);
      graph.addBetween(i, j, z, omega);
      addReference(ref, i, j, poses[i], poses[j], z, omega);
    }
    graph.commit();

    // A random column order; each column's rows are its later neighbours.
    std::vector<Index> variable_at(kVariables);
    std::iota(variable_at.begin(), variable_at.end(), 0);
    std::shuffle(variable_at.begin(), variable_at.end(), rng);
    std::vector<Index> position(kVariables);
    for (Index k = 0; k < kVariables; ++k) position[variable_at[k]] = k;
    std::vector<Index> start(kVariables);
    std::vector<std::vector<Index>> rows(kVariables);
    Index pool_size = 0;
    for (Index k = 0; k < kVariables; ++k) {
      rows[k].push_back(k);
      for (Index u : ref.neighbours[variable_at[k]])
        if (position[u] > k) rows[k].push_back(position[u]);
      std::sort(rows[k].begin() + 1, rows[k].end());
      start[k] = pool_size;
      pool_size += static_cast<Index>(rows[k].size());
    }
    std::vector<Mat3> pool(pool_size, Mat3::Zero());
    std::vector<Mat3> diagonal(kVariables, Mat3::Zero());
    std::vector<Vec3> eta(kVariables, Vec3::Zero());
    std::vector<Index> slot(kVariables, -1);
    LaterDiagonals<3> later(diagonal.data(), eta.data());
    for (Index k = 0; k < kVariables; ++k) {
      pool[start[k]] = diagonal[k];  // what the earlier columns sent
      for (std::size_t b = 0; b < rows[k].size(); ++b) slot[rows[k][b]] = static_cast<Index>(b);
      ColumnAccumulator<3> acc(pool.data() + start[k], slot.data(), &eta[k]);
      graph.assembleColumn(variable_at[k], position.data(), acc, later);
    }

    double worst = 0.0;
    const double scale = ref.lambda.cwiseAbs().maxCoeff();
    for (Index k = 0; k < kVariables; ++k) {
      const Index v = variable_at[k];
      worst = std::max(worst, maxAbsDiff(eta[k], ref.eta.segment<3>(3 * v)));
      for (std::size_t b = 0; b < rows[k].size(); ++b) {
        const Index u = variable_at[rows[k][b]];
        worst =
            std::max(worst, maxAbsDiff(pool[start[k] + b], ref.lambda.block<3, 3>(3 * u, 3 * v)));
      }
    }
    CHECK(worst <= 1e-6 * scale);
  }
}

namespace {

// Every block and eta a full assembly in the given column order produces (structure: each
// column's later neighbours), flattened for an exact comparison.
std::vector<double> assembleAll(const PoseGraph2D& graph, const std::vector<Index>& variable_at) {
  const Index n = static_cast<Index>(variable_at.size());
  std::vector<Index> position(n);
  for (Index k = 0; k < n; ++k) position[variable_at[k]] = k;
  std::vector<Mat3> diagonal(n, Mat3::Zero());
  std::vector<Vec3> eta(n, Vec3::Zero());
  LaterDiagonals<3> later(diagonal.data(), eta.data());
  std::vector<Index> slot(n, -1);
  std::vector<double> out;
  for (Index k = 0; k < n; ++k) {
    // Slots for every position after k (those without a factor stay zero).
    std::vector<Mat3> blocks(n - k, Mat3::Zero());
    blocks[0] = diagonal[k];
    for (Index r = k; r < n; ++r) slot[r] = r - k;
    ColumnAccumulator<3> acc(blocks.data(), slot.data(), &eta[k]);
    graph.assembleColumn(variable_at[k], position.data(), acc, later);
    for (const Mat3& b : blocks) out.insert(out.end(), b.data(), b.data() + 9);
    out.insert(out.end(), eta[k].data(), eta[k].data() + 3);
  }
  return out;
}

// The in-place path's change of every column (new minus old shares of the factors that moved).
std::vector<double> assembleAllChanges(const PoseGraph2D& graph) {
  const Index n = graph.variables();
  std::vector<Index> position(n);
  std::iota(position.begin(), position.end(), 0);
  std::vector<Index> slot(n);
  std::vector<double> out;
  for (Index k = 0; k < n; ++k) {
    std::vector<Mat3> blocks(n - k, Mat3::Zero());
    Vec3 eta = Vec3::Zero();
    for (Index r = k; r < n; ++r) slot[r] = r - k;
    ColumnAccumulator<3> acc(blocks.data(), slot.data(), &eta);
    graph.assembleColumnChange(k, position.data(), acc);
    for (const Mat3& b : blocks) out.insert(out.end(), b.data(), b.data() + 9);
    out.insert(out.end(), eta.data(), eta.data() + 3);
  }
  return out;
}

bool sameBits(const std::vector<double>& a, const std::vector<double>& b) {
  // (memcmp must not see the null data() of an empty vector.)
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

}  // namespace

namespace lslam {
struct PoseGraph2DTestAccess {
  static void startEpochAt(PoseGraph2D& graph, std::uint32_t epoch) { graph.epoch_ = epoch; }
};
}  // namespace lslam

namespace {

// Two graphs fed the same updates, one keeping linearizations, one computing every one afresh.
// Updates add poses and factors, stage relinearizations, assemble (full and in place), and then
// commit, roll back, or unstage first: a cache entry that outlived its points would differ. The
// cached graph's epochs start at first_epoch (near the wrap, to pass through it).
void checkCacheAgainstFresh(std::uint32_t first_epoch, unsigned seed) {
  constexpr Index kMaxVariables = 24;
  constexpr Index kMaxFactors = 80;
  std::mt19937 rng(seed);
  auto with_cache = std::make_unique<StaticPoseGraph2DStorage<kMaxVariables, kMaxFactors>>();
  auto without = std::make_unique<StaticPoseGraph2DStorage<kMaxVariables, kMaxFactors, false>>();
  int compared = 0;
  int hits_possible = 0;
  for (int c = 0; c < 40; ++c) {
    CAPTURE(c);
    PoseGraph2D cached(with_cache->arrays());
    PoseGraph2D fresh(without->arrays());
    PoseGraph2DTestAccess::startEpochAt(cached, first_epoch);
    std::uniform_int_distribution<int> coin(0, 3);
    for (int u = 0; u < 30; ++u) {
      CAPTURE(u);
      cached.beginUpdate();
      fresh.beginUpdate();
      const Index n = cached.variables();
      const bool add = n < 4 || (n < kMaxVariables && coin(rng) != 0);
      if (add) {
        const SE2 p = randomPose(rng, c + u);
        cached.addVariable(p);
        fresh.addVariable(p);
      }
      const Index m = cached.variables();
      std::uniform_int_distribution<Index> pick(0, m - 1);
      const int new_factors = m < 2 || cached.factors() + 3 > kMaxFactors ? 0 : 1 + coin(rng) % 3;
      for (int f = 0; f < new_factors; ++f) {
        const Index i = add && f == 0 ? m - 2 : pick(rng);
        Index j = add && f == 0 ? m - 1 : pick(rng);
        if (i == j) j = (i + 1) % m;
        const SE2 z = randomPose(rng, f);
        const Mat3 omega = randomInformation(rng);
        cached.addBetween(i, j, z, omega);
        fresh.addBetween(i, j, z, omega);
      }
      // Stage some relinearizations of committed variables.
      for (Index v = 0; v < n; ++v) {
        if (coin(rng) != 0) continue;
        const SE2 p = randomPose(rng, c + static_cast<int>(v));
        cached.relinearize(v, p);
        fresh.relinearize(v, p);
      }
      const int ending = coin(rng);  // 0: unstage first, 1: roll back, else commit
      if (ending == 0) {
        cached.unstageRelinearization();
        fresh.unstageRelinearization();
      }
      std::vector<Index> variable_at(m);
      std::iota(variable_at.begin(), variable_at.end(), 0);
      std::shuffle(variable_at.begin(), variable_at.end(), rng);
      // A full assembly in some updates only, so that points also move under kept entries that
      // no full assembly replaced; twice, so that the second reads what the first kept.
      const int full_assemblies = coin(rng) % 3;
      for (int a = 0; a < full_assemblies; ++a) {
        CHECK(sameBits(assembleAll(cached, variable_at), assembleAll(fresh, variable_at)));
        if (a == 0) CHECK(sameBits(assembleAllChanges(cached), assembleAllChanges(fresh)));
        ++compared;
      }
      hits_possible += cached.factors() > 0 ? 1 : 0;
      if (ending == 1) {
        cached.rollback();
        fresh.rollback();
      } else {
        cached.commit();
        fresh.commit();
      }
    }
  }
  CHECK(compared > 40 * 30 / 2);
  CHECK(hits_possible > 0);
}

}  // namespace

TEST_CASE("the linearization cache gives what a fresh linearization gives, bit for bit") {
  checkCacheAgainstFresh(1, kSeed + 1);
}

TEST_CASE("the linearization cache forgets everything when its epoch wraps") {
  // 30 updates advance the epoch by up to 60: starting 20 below the wrap passes through it.
  checkCacheAgainstFresh(std::numeric_limits<std::uint32_t>::max() - 20, kSeed + 2);
}

namespace {

sim::Pose2D toPose2D(const SE2& p) {
  return sim::Pose2D{p.x(), p.y(), p.theta()};
}

// A factor's share of Lambda (6 x 6 over its variables first, second; 3 x 3 for a prior) and of
// eta.
struct Share {
  Eigen::MatrixXd lambda;
  Eigen::VectorXd eta;
};

// The reference share of e^T Omega e, from host_sim's analytic g2o Jacobians (independent of
// firmware_lib; the same first derivatives as the right perturbation) and the symmetric part of
// Omega: J^T Omega_s J and -J^T Omega_s e. A prior is an edge from the identity pose.
Share referenceShare(const SE2* first, const SE2& second, const SE2& z, const Mat3& omega) {
  const Mat3 symmetric = 0.5 * (omega + omega.transpose());
  const sim::Pose2D xi = first != nullptr ? toPose2D(*first) : sim::Pose2D{};
  Eigen::Matrix3d j_i;
  Eigen::Matrix3d j_j;
  sim::edgeJacobiansG2o(xi, toPose2D(second), toPose2D(z), &j_i, &j_j);
  const Eigen::Vector3d e = sim::edgeErrorG2o(xi, toPose2D(second), toPose2D(z));
  Eigen::MatrixXd j(3, first != nullptr ? 6 : 3);
  if (first != nullptr) {
    j << j_i, j_j;
  } else {
    j = j_j;
  }
  return Share{j.transpose() * symmetric * j, -(j.transpose() * symmetric * e)};
}

// The same share as the row update takes it: A^T A and A^T b of the whitened rows.
Share whitenedShare(const PoseGraph2D& graph, Index factor) {
  const Index position[2] = {0, 1};
  Index positions[2];
  Mat3 rows[2];
  Vec3 rhs;
  const Index count = graph.whitenedRows(factor, position, positions, rows, &rhs);
  Share s{Eigen::MatrixXd::Zero(3 * count, 3 * count), Eigen::VectorXd::Zero(3 * count)};
  for (Index a = 0; a < count; ++a) {
    s.eta.segment<3>(3 * positions[a]) = rows[a] * rhs;
    for (Index b = 0; b < count; ++b)
      s.lambda.block<3, 3>(3 * positions[a], 3 * positions[b]) = rows[a] * rows[b].transpose();
  }
  return s;
}

// ...and as a full assembly takes it (the graph holding that one factor): the lower triangle.
Share assembledShare(const PoseGraph2D& graph) {
  const Index n = graph.variables();
  std::vector<Index> variable_at(n);
  std::iota(variable_at.begin(), variable_at.end(), 0);
  const std::vector<double> all = assembleAll(graph, variable_at);
  Share s{Eigen::MatrixXd::Zero(3 * n, 3 * n), Eigen::VectorXd::Zero(3 * n)};
  std::size_t at = 0;
  for (Index k = 0; k < n; ++k) {
    for (Index r = k; r < n; ++r, at += 9) {
      const Mat3 block = Eigen::Map<const Mat3>(all.data() + at);
      s.lambda.block<3, 3>(3 * r, 3 * k) = block;
      if (r > k) s.lambda.block<3, 3>(3 * k, 3 * r) = block.transpose();
    }
    s.eta.segment<3>(3 * k) = Eigen::Map<const Vec3>(all.data() + at);
    at += 3;
  }
  return s;
}

double shareError(const Share& a, const Share& reference) {
  const double scale = reference.lambda.cwiseAbs().maxCoeff() + reference.eta.cwiseAbs().maxCoeff();
  return std::max((a.lambda - reference.lambda).cwiseAbs().maxCoeff(),
                  (a.eta - reference.eta).cwiseAbs().maxCoeff()) /
         scale;
}

}  // namespace

TEST_CASE(
    "information symmetric only to rounding: the assembled column and the whitened rows both "
    "take its symmetric part") {
  // Omega far from isotropic (the heading's information 1e8), its (1, 2) pair apart by 0.9e-9 of
  // that, inside checkInformation's tolerance: 0.09 beside the 1 of y, which the share of Lambda
  // shows far above rounding (1e-16 of 1e8).
  std::mt19937 rng(kSeed + 3);
  auto storage = std::make_unique<StaticPoseGraph2DStorage<2, 1>>();
  for (int c = 0; c < 200; ++c) {
    CAPTURE(c);
    Mat3 omega;
    omega << 5.0, 0.3, 0.2,  //
        0.3, 1.0, 0.1,       //
        0.2, 0.1, 1e8;
    omega(1, 2) += 0.45e-9 * 1e8;
    omega(2, 1) -= 0.45e-9 * 1e8;
    REQUIRE(checkInformation(omega) == Status::Ok);
    const SE2 xi = randomPose(rng, c);
    const SE2 xj = randomPose(rng, c + 1);
    const SE2 z =
        fromMatrix(toMatrix(xi).inverse() * toMatrix(xj) * expMatrix(0.2 * randomTangent(rng, c)));
    for (const bool prior : {false, true}) {
      CAPTURE(prior);
      PoseGraph2D graph(storage->arrays());
      graph.beginUpdate();
      if (prior) {
        graph.addVariable(xj);
        graph.addPrior(0, z, omega);
      } else {
        graph.addVariable(xi);
        graph.addVariable(xj);
        graph.addBetween(0, 1, z, omega);
      }
      graph.commit();
      const Share reference = referenceShare(prior ? nullptr : &xi, xj, z, omega);
      CHECK(shareError(whitenedShare(graph, 0), reference) < 1e-14);
      CHECK(shareError(assembledShare(graph), reference) < 1e-14);
    }
  }
}
