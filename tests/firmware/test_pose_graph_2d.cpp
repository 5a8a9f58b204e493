// PoseGraph2D as the factorization's source of Lambda and eta: the assembly that linearizes each
// factor once (adding to the later variable's diagonal and eta ahead of time) against a dense
// J^T Omega J built from central-difference Jacobians, in random column orders.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <vector>

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
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
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
