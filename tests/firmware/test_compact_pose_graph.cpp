// CompactPoseGraph (mapping past the smoother's pose capacity) and the smoother's folded factors
// (Smoother::addFolded, FactorGraph::foldNewestFactor, mergedMeasurement), against dense Eigen, a
// twin smoother given the measurement as a factor of its own, the truth of a synthetic world and
// the independent batch solver.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "host_sim/batch_solver.h"
#include "host_sim/steps.h"
#include "host_sim/synthetic.h"
#include "lslam/factors/merged_measurement.h"
#include "lslam/factors/se3_factors.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/solver/compact_pose_graph.h"
#include "lslam/solver/smoother.h"

using namespace lslam;
using namespace lslam::sim;

namespace {

using Fac = ModelFactorInput<PoseSlam2D>;
using Var = ModelVariableInput<PoseSlam2D>;
using Graph = CompactPoseGraph<PoseSlam2D>;
using Closure = PlaceClosure<SE2>;
// Room for a dense 200-pose factor and its staging copy.
using CompactSmoother = StaticSmoother<PoseSlam2D, 200, 0, 801, 801 * 12, 50000, 0>;
using TwinSmoother = StaticSmoother<PoseSlam2D, 64, 0, 256, 256 * 12, 8000, 0>;

SE2 toSE2(const Pose2D& p) {
  return SE2(p.x, p.y, p.theta);
}

// One step of a synthetic world: its odometry and its loop closures (from earlier poses).
struct WorldStep {
  std::int64_t pose = -1;
  const Edge2D* odometry = nullptr;
  std::vector<const Edge2D*> closures;
};

std::vector<WorldStep> worldSteps(const Dataset2D& d) {
  std::vector<WorldStep> out;
  for (const Step& s : buildSteps(d, StepOrder::Online)) {
    WorldStep w;
    w.pose = s.new_pose;
    for (std::size_t e : s.edges) {
      const Edge2D& edge = d.edges[e];
      REQUIRE(edge.to == s.new_pose);
      if (edge.from == s.new_pose - 1 && w.odometry == nullptr) {
        w.odometry = &edge;
      } else {
        w.closures.push_back(&edge);
      }
    }
    out.push_back(w);
  }
  return out;
}

// A step's loop closures from the places kept for earlier poses.
std::vector<Closure> closuresOf(const WorldStep& w, const std::vector<Place<SE2>>& places) {
  std::vector<Closure> c;
  for (const Edge2D* e : w.closures) {
    c.push_back(
        Closure{places[static_cast<std::size_t>(e->from)], toSE2(e->measurement), e->information});
  }
  return c;
}

// Position RMS of estimates against the truth after the rigid motion that best aligns them (2D
// closed form).
double alignedRms(const std::vector<Vec2>& estimate, const std::vector<Vec2>& truth) {
  const auto n = static_cast<double>(estimate.size());
  Vec2 ea = Vec2::Zero();
  Vec2 ta = Vec2::Zero();
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    ea += estimate[i] / n;
    ta += truth[i] / n;
  }
  double c = 0.0;
  double s = 0.0;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const Vec2 e = estimate[i] - ea;
    const Vec2 t = truth[i] - ta;
    c += e.dot(t);
    s += e.x() * t.y() - e.y() * t.x();
  }
  const double angle = std::atan2(s, c);
  const Eigen::Rotation2Dd r(angle);
  double sum = 0.0;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    sum += (r * (estimate[i] - ea) - (truth[i] - ta)).squaredNorm();
  }
  return std::sqrt(sum / n);
}

// A 40-pose chain with loop closures, in a twin-sized smoother.
void feedChain(Smoother<PoseSlam2D>& solver) {
  const Mat3 info = Vec3(400.0, 400.0, 10000.0).asDiagonal();
  const Var first = Var::make(0, SE2());
  REQUIRE(solver.update(&first, 1, nullptr, 0) == Status::Ok);
  for (VariableId i = 1; i < 40; ++i) {
    const SE2 z(1.0, 0.02 * static_cast<double>(i % 3), 0.16);
    const Var v = Var::make(i, solver.estimateAt<SE2>(static_cast<Index>(i - 1)).compose(z));
    std::vector<Fac> f = {Fac::make<BetweenSE2Factor>(i - 1, i, z, info)};
    if (i >= 12 && i % 4 == 0) {
      const SE2 seen = solver.estimateAt<SE2>(static_cast<Index>(i - 12));
      f.push_back(Fac::make<BetweenSE2Factor>(
          i - 12, i, seen.inverse().compose(v.get<SE2>()).compose(SE2(0.01, -0.02, 0.003)), info));
    }
    REQUIRE(solver.update(&v, 1, f.data(), static_cast<Index>(f.size())) == Status::Ok);
  }
}

// The between factor joining graph variables a -> b.
Index factorOf(const Smoother<PoseSlam2D>& solver, Index a, Index b) {
  for (Index f = 0; f < solver.factors(); ++f) {
    if (solver.graph().firstVariable(f) == a && solver.graph().secondVariable(f) == b) return f;
  }
  return kNoIndex;
}

SyntheticWorld manhattanWorld(int poses, unsigned seed) {
  SyntheticOptions o;
  o.poses = poses;
  o.seed = seed;
  return generateManhattanWorld(o);
}

// Feeds every step of `steps` (a synthetic world's) to a compact graph on `solver`, each loop
// closure from the place kept for the pose it sees; after(s, status, result) follows each step.
// Returns every step's place.
template <class After>
std::vector<Place<SE2>> runSteps(Smoother<PoseSlam2D>& solver, const SyntheticWorld& world,
                                 const std::vector<WorldStep>& steps, After after) {
  Graph graph(solver);
  std::vector<Place<SE2>> places(steps.size());
  REQUIRE(graph.start(toSE2(world.dataset.vertices.front().pose)) == Status::Ok);
  places[0] = graph.current();
  for (std::size_t s = 1; s < steps.size(); ++s) {
    const WorldStep& w = steps[s];
    REQUIRE(w.odometry != nullptr);
    const std::vector<Closure> closures = closuresOf(w, places);
    CompactStepResult r;
    const Status status = graph.addStep(toSE2(w.odometry->measurement), w.odometry->information,
                                        closures.data(), static_cast<Index>(closures.size()), &r);
    places[s] = graph.current();
    after(s, status, r);
  }
  return places;
}

}  // namespace

TEST_CASE("mergedMeasurement: the information-weighted mean of two measurements a shift apart") {
  // Same rotation: z2 = z1 Exp((d, 0)) is a translation in z1's frame, where the mean is linear.
  const SE2 z1(1.0, 2.0, 0.3);
  const Vec2 shift(0.08, -0.05);
  const SE2 z2 = z1.compose(SE2(shift.x(), shift.y(), 0.0));
  const Mat3 o1 = Vec3(100.0, 400.0, 900.0).asDiagonal();
  Mat3 o2;
  o2 << 300.0, 50.0, 0.0, 50.0, 200.0, 0.0, 0.0, 0.0, 500.0;
  Mat3 merged_information;
  const SE2 z = mergedMeasurement(z1, o1, z2, o2, &merged_information);
  // Dense: argmin_t |t|^2_O1 + |t - shift|^2_O2 over the translation in z1's frame.
  const Mat2 a = o1.topLeftCorner<2, 2>() + o2.topLeftCorner<2, 2>();
  const Vec2 t = a.ldlt().solve(o2.topLeftCorner<2, 2>() * shift);
  const SE2 expected = z1.compose(SE2(t.x(), t.y(), 0.0));
  CHECK(z.x() == doctest::Approx(expected.x()).epsilon(1e-12));
  CHECK(z.y() == doctest::Approx(expected.y()).epsilon(1e-12));
  CHECK(z.theta() == doctest::Approx(z1.theta()).epsilon(1e-12));
  CHECK((merged_information - (o1 + o2)).norm() == 0.0);
}

TEST_CASE("addFolded factors as a second factor would and keeps one factor of the pair") {
  auto folded = std::make_unique<TwinSmoother>();
  auto twin = std::make_unique<TwinSmoother>();
  feedChain(*folded);
  feedChain(*twin);
  const Index existing = factorOf(*folded, 24, 36);
  REQUIRE(existing != kNoIndex);
  const Mat3 info = Vec3(250.0, 300.0, 8000.0).asDiagonal();
  const SE2 z =
      folded->graph().measurement<BetweenSE2Factor>(existing).compose(SE2(0.03, 0.01, -0.004));
  const Fac again = Fac::make<BetweenSE2Factor>(24, 36, z, info);
  UpdateResult r;
  REQUIRE(folded->addFolded(again, existing, &r) == Status::Ok);
  REQUIRE(twin->update(nullptr, 0, &again, 1) == Status::Ok);
  CHECK(folded->factors() + 1 == twin->factors());
  // The same factorization, so the same solution, bit for bit.
  for (Index v = 0; v < folded->variables(); ++v) {
    CHECK(folded->deltaAt(v) == twin->deltaAt(v));
  }
  // The graph holds the merged measurement in place of the first.
  Mat3 merged_info;
  const SE2 merged = mergedMeasurement(twin->graph().measurement<BetweenSE2Factor>(existing),
                                       twin->graph().information<BetweenSE2Factor>(existing), z,
                                       info, &merged_info);
  CHECK(folded->graph().measurement<BetweenSE2Factor>(existing).vector() == merged.vector());
  CHECK(folded->graph().information<BetweenSE2Factor>(existing) == merged_info);
  // Both still solve the same problem to first order: a full optimization lands on chi2 values
  // that differ by the fold's second-order term only.
  REQUIRE(folded->optimize(20, 1e-10) == Status::Ok);
  REQUIRE(twin->optimize(20, 1e-10) == Status::Ok);
  for (Index v = 0; v < folded->variables(); ++v) {
    const SE2 a = folded->estimateAt<SE2>(v);
    const SE2 b = twin->estimateAt<SE2>(v);
    CHECK((a.translation() - b.translation()).norm() < 1e-4);
  }
}

TEST_CASE("addFolded refuses what it cannot fold and changes nothing") {
  auto solver = std::make_unique<TwinSmoother>();
  feedChain(*solver);
  const Index existing = factorOf(*solver, 24, 36);
  REQUIRE(existing != kNoIndex);
  const Mat3 info = Mat3::Identity() * 100.0;
  const Fac good = Fac::make<BetweenSE2Factor>(24, 36, SE2(1.0, 0.0, 0.1), info);
  Fac nan = good;
  nan.measurement[0] = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    Fac factor;
    Index into;
    Status expected;
  };
  const Case cases[] = {
      {good, -1, Status::InvalidArgument},
      {good, solver->factors(), Status::InvalidArgument},
      {good, solver->anchorFactor() == kNoIndex ? 0 : solver->anchorFactor(),
       Status::InvalidArgument},
      {Fac::make<BetweenSE2Factor>(36, 24, SE2(), info), existing, Status::InvalidArgument},
      {Fac::make<BetweenSE2Factor>(23, 36, SE2(), info), existing, Status::InvalidArgument},
      {Fac::make<BetweenSE2Factor>(24, 99, SE2(), info), existing, Status::InvalidArgument},
      {Fac::make<PriorSE2Factor>(24, SE2(), info), existing, Status::InvalidArgument},
      {nan, existing, Status::NonFiniteInput},
  };
  const Index factors = solver->factors();
  std::vector<Vec3> before;
  for (Index v = 0; v < solver->variables(); ++v) before.push_back(solver->deltaAt(v));
  const double chi2 = solver->chi2();
  for (const Case& c : cases) {
    UpdateResult r;
    CHECK(solver->addFolded(c.factor, c.into, &r) == c.expected);
    CHECK(r.status == c.expected);
    CHECK(solver->factors() == factors);
    CHECK(solver->chi2() == chi2);
    for (Index v = 0; v < solver->variables(); ++v) CHECK(solver->deltaAt(v) == before[v]);
  }
  CHECK(solver->addFolded(good, existing) == Status::Ok);
  CHECK(solver->factors() == factors);
}

TEST_CASE("a compact graph of 200 poses maps a revisit-heavy world for 5000 steps") {
  const SyntheticWorld world = manhattanWorld(5000, 11);
  const std::vector<WorldStep> steps = worldSteps(world.dataset);
  auto solver = std::make_unique<CompactSmoother>();
  Index folded = 0;
  Index dropped = 0;
  Index late_folds = 0;  // in the last 1,000 steps
  Index not_ok = 0;
  const std::vector<Place<SE2>> places = runSteps(
      *solver, world, steps, [&](std::size_t s, Status status, const CompactStepResult& r) {
        not_ok += status == Status::Ok ? 0 : 1;
        solver->solve(false);
        folded += r.folded;
        dropped += r.dropped;
        late_folds += s + 1000 >= steps.size() ? r.folded : 0;
        CHECK(r.node_added == (s < 200));
      });
  CHECK(not_ok == 0);
  CHECK(solver->poses() == 200);
  CHECK(solver->factors() <= CompactSmoother::max_factors);
  MESSAGE("folded " << folded << ", dropped " << dropped << ", factors " << solver->factors());
  CHECK(folded > 300);    // the graph keeps learning past its capacity...
  CHECK(late_folds > 0);  // ...to the end

  // The map (the 200 nodes) against the truth, and against the independent batch optimum of the
  // first 200 steps (the map the capacity would have frozen): the compact map holds those
  // measurements and every later one (folded or as new pairs), so it is no worse.
  Dataset2D first;
  for (std::size_t i = 0; i < 200; ++i) first.vertices.push_back(world.dataset.vertices[i]);
  for (const Edge2D& e : world.dataset.edges) {
    if (e.to < 200) first.edges.push_back(e);
  }
  Estimate2D initial;
  for (const Vertex2D& v : first.vertices) initial[v.id] = v.pose;
  BatchOptions batch_options;
  batch_options.fixed = {0};
  const BatchResult batch = solveBatch2D(first, initial, batch_options);
  REQUIRE(batch.converged);
  std::vector<Vec2> nodes;
  std::vector<Vec2> batch_nodes;
  std::vector<Vec2> truth;
  for (Index v = 0; v < 200; ++v) {
    nodes.push_back(solver->estimateAt<SE2>(v).translation());
    const Pose2D& b = batch.poses.at(v);
    batch_nodes.push_back(Vec2(b.x, b.y));
    truth.push_back(Vec2(world.ground_truth[v].x, world.ground_truth[v].y));
  }
  const double compact_rms = alignedRms(nodes, truth);
  const double batch_rms = alignedRms(batch_nodes, truth);
  MESSAGE("map RMS against the truth: compact " << compact_rms << " m, batch of the first 200 "
                                                << batch_rms << " m");
  CHECK(compact_rms <= batch_rms);

  // Each later pose's offset from its node against the true relative pose. Its covariance holds
  // the measurements' noise, so the squared Mahalanobis error would be chi-square with 3 degrees
  // of freedom (mean 3) for a place never carried to another node; a carried place also holds
  // the nodes' estimation error, which the covariance leaves out (the map is taken as exact), and
  // poses along a chain share noise. The band catches a covariance off by a factor of 2 or more
  // in the measurements' share (a mean below 1.5), or one that misses the measurements (a
  // mean far above the map's share: 10).
  double sum = 0.0;
  Index count = 0;
  for (std::size_t s = 200; s < steps.size(); ++s) {
    const Place<SE2>& p = places[s];
    if (p.atNode()) continue;
    const SE2 node = toSE2(world.ground_truth[static_cast<std::size_t>(p.node)]);
    const SE2 true_offset = node.inverse().compose(toSE2(world.ground_truth[s]));
    const Vec3 e = true_offset.localCoordinates(p.offset);
    sum += e.dot(p.covariance.ldlt().solve(e));
    ++count;
  }
  const double mean = sum / static_cast<double>(count);
  MESSAGE("offsets' mean squared Mahalanobis error " << mean << " over " << count << " poses");
  CHECK(mean > 1.5);
  CHECK(mean < 10.0);
}

TEST_CASE(
    "past the capacity an observation of a mapped landmark folds into the current node's factor "
    "of it, if the graph has one, and corrects the place either way") {
  // Six nodes (0..5) on a line; landmark 100 seen from nodes 0 and 5, landmark 101 from node 0
  // only. Past the capacity the places ride on node 5: 100 folds into the factor 5 -> 100, 101
  // (no factor 5 -> 101) only corrects the place; no factor is added.
  using Landmarks = CompactPoseGraph<Slam2D>;
  auto solver = std::make_unique<StaticSmoother<Slam2D, 6, 4, 40, 40 * 12, 2000, 2000 * 9>>();
  Landmarks graph(*solver);
  const Mat3 odometry_information = Vec3(100.0, 100.0, 400.0).asDiagonal();
  const SE2 step(1.0, 0.0, 0.0);
  const auto seen = [](VariableId landmark, const SE2& robot, const Vec2& where) {
    return Landmarks::Observation{landmark, robot.inverse().transformFrom(where),
                                  Mat2::Identity() * 100.0};
  };
  const Vec2 l100(3.0, 2.0);
  const Vec2 l101(1.0, -2.0);
  REQUIRE(graph.start(SE2()) == Status::Ok);
  const Landmarks::Observation first[2] = {seen(100, SE2(), l100), seen(101, SE2(), l101)};
  REQUIRE(graph.addObservations(first, 2) == Status::Ok);
  SE2 truth;
  for (int k = 1; k <= 5; ++k) {
    truth = truth.compose(step);
    const Landmarks::Observation at_five = seen(100, truth, l100);
    CompactStepResult r;
    REQUIRE(graph.addStep(step, odometry_information, nullptr, 0, &at_five, k == 5 ? 1 : 0, &r) ==
            Status::Ok);
    REQUIRE(r.node_added);
  }
  const auto& g = solver->graph();
  const Index l100_index = solver->indexOf<Point2>(100);
  Index pair = kNoIndex;
  for (Index f = 0; f < g.factors(); ++f) {
    if (g.firstVariable(f) == solver->indexOf<SE2>(5) && g.secondVariable(f) == l100_index)
      pair = f;
  }
  REQUIRE(pair != kNoIndex);
  const Mat2 before = g.information<PointObservationSE2Factor>(pair);
  const Index factors = solver->factors();
  truth = truth.compose(step);
  const Landmarks::Observation later[2] = {seen(100, truth, l100), seen(101, truth, l101)};
  CompactStepResult r;
  REQUIRE(graph.addStep(step, odometry_information, nullptr, 0, later, 2, &r) == Status::Ok);
  CHECK_FALSE(r.node_added);
  CHECK(r.folded == 1);
  CHECK(r.localized == 2);
  CHECK(r.factors_added == 0);
  CHECK(r.dropped == 0);
  CHECK(solver->factors() == factors);
  // The fold added the observation's information, carried through the place's offset.
  const Mat2 after = g.information<PointObservationSE2Factor>(pair);
  CHECK(after.trace() > before.trace());
  CHECK((after - before).eval().llt().info() == Eigen::Success);
}

TEST_CASE("at its pool share a grown factor is reordered for room before a pair is dropped") {
  // The pool of CompactSmoother cut so that the live factor reaches kNewPairPoolShare of it.
  using SmallPool = StaticSmoother<PoseSlam2D, 200, 0, 801, 801 * 12, 3400, 0>;
  const SyntheticWorld world = manhattanWorld(3000, 11);
  const std::vector<WorldStep> steps = worldSteps(world.dataset);
  auto solver = std::make_unique<SmallPool>();
  Index reordered = 0;
  Index dropped = 0;
  Index added = 0;
  Index not_ok = 0;
  runSteps(*solver, world, steps, [&](std::size_t s, Status status, const CompactStepResult& r) {
    not_ok += status == Status::Ok ? 0 : 1;
    if (s < 200) return;
    reordered += r.reordered_for_room ? 1 : 0;
    CHECK((r.reordered || !r.reordered_for_room));
    added += r.factors_added;
    dropped += r.dropped;
    if (r.dropped > 0) {
      // A drop only with the factor at its share and not grown enough since its last order to
      // reorder for room (or with no factor slot left).
      CAPTURE(s);
      CHECK(static_cast<double>(solver->factorBlocks()) >
            Graph::kNewPairPoolShare * static_cast<double>(SmallPool::max_factor_blocks) -
                static_cast<double>(SmallPool::max_factor_blocks) / 10.0);
      CHECK((static_cast<double>(solver->factorBlocks()) <
                 Graph::kRoomReorderGrowth * static_cast<double>(solver->blocksAtLastOrder()) ||
             solver->factors() + 2 > SmallPool::max_factors));
    }
  });
  MESSAGE("past the capacity: " << reordered << " steps reordered for room, " << added
                                << " pairs added, " << dropped << " dropped, live blocks "
                                << solver->factorBlocks());
  CHECK(not_ok == 0);
  CHECK(reordered > 0);
  CHECK(added > 0);
}

TEST_CASE("a rejected step past capacity changes nothing") {
  const SyntheticWorld world = manhattanWorld(400, 5);
  const std::vector<WorldStep> steps = worldSteps(world.dataset);
  auto solver = std::make_unique<TwinSmoother>();
  Graph graph(*solver);
  std::vector<Place<SE2>> places(steps.size());
  REQUIRE(graph.start(toSE2(world.dataset.vertices.front().pose)) == Status::Ok);
  places[0] = graph.current();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Index rejected = 0;
  for (std::size_t s = 1; s < steps.size(); ++s) {
    const WorldStep& w = steps[s];
    const std::vector<Closure> closures = closuresOf(w, places);
    const SE2 z = toSE2(w.odometry->measurement);
    const Mat3& info = w.odometry->information;
    if (s > 100 && s % 7 == 0 && !closures.empty()) {
      std::vector<Closure> bad_node = closures;
      bad_node[0].seen.node = 1000;
      std::vector<Closure> bad_info = closures;
      bad_info[0].information(2, 2) = -1.0;
      std::vector<Closure> bad_covariance = closures;
      bad_covariance[0].seen.covariance(0, 1) = 1.0;
      std::vector<Closure> indefinite = closures;  // symmetric, an eigenvalue below zero
      indefinite[0].seen.covariance = Vec3(1e-4, -1e-4, 1e-6).asDiagonal();
      std::vector<Closure> weak_closure = closures;
      weak_closure[0].information(0, 0) = 1e-19;
      std::vector<Closure> moved_node = closures;  // zero covariance (a node) but an offset
      moved_node[0].seen = Place<SE2>{0, SE2(0.5, 0.0, 0.0), Mat3::Zero()};
      struct Bad {
        SE2 odometry;
        Mat3 information;
        const std::vector<Closure>* closures;
        Index count;
        Status expected;
      };
      const Bad bad[] = {
          {SE2(nan, 0.0, 0.0), info, &closures, 1, Status::NonFiniteInput},
          {z, -info, &closures, 1, Status::InformationNotPositiveDefinite},
          {z, info, &bad_node, 1, Status::UnknownVariable},
          {z, info, &bad_info, 1, Status::InformationNotPositiveDefinite},
          {z, info, &bad_covariance, 1, Status::InvalidArgument},
          {z, info, &closures, -1, Status::InvalidArgument},
          {z, info, &indefinite, 1, Status::InvalidArgument},
          {z, info, &moved_node, 1, Status::InvalidArgument},
          // Positive definite, but a standard deviation beyond kMaxCoordinate (sqrt(1e19) m).
          {z, Mat3::Identity() * 1e-19, &closures, 1, Status::InvalidArgument},
          {z, info, &weak_closure, 1, Status::InvalidArgument},
      };
      const double chi2 = solver->chi2();
      const Index factors = solver->factors();
      const Place<SE2> current = graph.current();
      std::vector<Vec3> deltas;
      for (Index v = 0; v < solver->variables(); ++v) deltas.push_back(solver->deltaAt(v));
      for (const Bad& b : bad) {
        CompactStepResult r;
        CHECK(graph.addStep(b.odometry, b.information, b.closures->data(), b.count, &r) ==
              b.expected);
        CHECK(r.status == b.expected);
        CHECK(solver->chi2() == chi2);
        CHECK(solver->factors() == factors);
        CHECK(graph.current().node == current.node);
        CHECK(graph.current().offset.vector() == current.offset.vector());
        CHECK(graph.current().covariance == current.covariance);
        for (Index v = 0; v < solver->variables(); ++v) CHECK(solver->deltaAt(v) == deltas[v]);
        ++rejected;
      }
    }
    REQUIRE(graph.addStep(z, info, closures.data(), static_cast<Index>(closures.size())) ==
            Status::Ok);
    places[s] = graph.current();
  }
  CHECK(graph.nodes() == 64);
  CHECK(rejected > 100);
}

TEST_CASE("a compact graph refuses steps before start() and observations of a pose-only model") {
  auto solver = std::make_unique<TwinSmoother>();
  Graph graph(*solver);
  const Mat3 info = Mat3::Identity() * 100.0;
  CompactStepResult r;
  CHECK(graph.addStep(SE2(1.0, 0.0, 0.0), info, nullptr, 0, &r) == Status::InvalidArgument);
  CHECK(solver->variables() == 0);
  REQUIRE(graph.start(SE2()) == Status::Ok);
  CHECK(graph.start(SE2()) == Status::InvalidArgument);  // once
  const Graph::Observation seen{};
  CHECK(graph.addStep(SE2(1.0, 0.0, 0.0), info, nullptr, 0, &seen, 1, &r) ==
        Status::InvalidArgument);
  CHECK(graph.addObservations(&seen, 1) == Status::InvalidArgument);
  CHECK(solver->variables() == 1);
  CHECK(graph.addStep(SE2(1.0, 0.0, 0.0), info, nullptr, 0, &r) == Status::Ok);
  CHECK(solver->variables() == 2);
}

TEST_CASE("reversedBetweenInformation: the same chi2 read from the other pose") {
  // For poses a little off a measurement z of xi -> xj, the between factor's chi2 e^T O e must
  // equal, to first order in the error, that of z^-1 from xj -> xi under the reversed information
  // (the factors' own error functions, in their own error coordinates).
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const SE3 z = SE3::exp(Vec6(n(rng), n(rng), n(rng), n(rng), n(rng), n(rng)));
    Mat6 a;
    for (int i = 0; i < 36; ++i) a(i / 6, i % 6) = n(rng);
    const Mat6 information = a * a.transpose() + Mat6::Identity();
    const Mat6 reversed = reversedBetweenInformation(z, information);
    const SE3 xi = SE3::exp(Vec6(n(rng), n(rng), n(rng), n(rng), n(rng), n(rng)));
    const Vec6 off = 1e-4 * Vec6(n(rng), n(rng), n(rng), n(rng), n(rng), n(rng));
    const SE3 xj = xi.compose(z).retract(off);
    const Vec6 forward = BetweenSE3Factor::error(xi, xj, z, nullptr, nullptr);
    const Vec6 backward = BetweenSE3Factor::error(xj, xi, z.inverse(), nullptr, nullptr);
    const double chi2 = forward.dot(information * forward);
    CHECK(backward.dot(reversed * backward) == doctest::Approx(chi2).epsilon(1e-3));
    // And back again.
    const Mat6 twice = reversedBetweenInformation(z.inverse(), reversed);
    CHECK((twice - information).norm() <= 1e-8 * information.norm());
  }
}

TEST_CASE(
    "past the capacity an extreme information is refused, or leaves every place and estimate "
    "finite") {
  // Six nodes, then places on them: at step 8 one measurement's information is pushed to an
  // extreme (the odometry's heading, a mapped landmark's observation, a loop closure's heading or
  // x). Below about 1e-18 (a standard deviation beyond kMaxCoordinate) the step is refused and
  // changes nothing. Above, up to the largest finite values: a Kalman correction or fusion that
  // double precision cannot resolve (J^T Omega J overflowing, or swamping the place's own
  // information) leaves the place as it was, which a twin never given that observation shows.
  using Landmarks = CompactPoseGraph<Slam2D>;
  using Solver = StaticSmoother<Slam2D, 6, 4, 40, 40 * 12, 2000, 2000 * 9>;
  const double extremes[] = {1e12,  1e100, 1e200, 4e302,  1e307, 1.5e308,
                             1e-12, 1e-17, 1e-19, 1e-300, 1e-310};
  const Vec2 landmark(3.0, 2.0);
  const auto seen = [&](const SE2& robot, double information_y) {
    Mat2 information = Mat2::Identity() * 100.0;
    information(1, 1) = information_y;
    return Landmarks::Observation{100, robot.inverse().transformFrom(landmark), information};
  };
  const auto samePlace = [](const Place<SE2>& a, const Place<SE2>& b) {
    return a.node == b.node && a.offset.vector() == b.offset.vector() &&
           a.covariance == b.covariance;
  };
  Index skipped_corrections = 0;
  for (int site = 0; site < 4; ++site) {
    for (const double extreme : extremes) {
      CAPTURE(site);
      CAPTURE(extreme);
      const bool refused = extreme < 1e-18;
      auto solver = std::make_unique<Solver>();
      auto twin_solver = std::make_unique<Solver>();  // never sees the pushed observation
      Landmarks graph(*solver);
      Landmarks twin(*twin_solver);
      const Landmarks::Observation first = seen(SE2(), 100.0);
      for (Landmarks* g : {&graph, &twin}) {
        REQUIRE(g->start(SE2()) == Status::Ok);
        REQUIRE(g->addObservations(&first, 1) == Status::Ok);
      }
      const SE2 step(1.0, 0.01, 0.01);
      const Mat3 normal = Vec3(100.0, 100.0, 400.0).asDiagonal();
      SE2 truth;
      std::vector<Place<SE2>> places{graph.current()};
      for (int k = 1; k <= 12; ++k) {
        truth = truth.compose(step);
        const bool pushed = k == 8;
        Mat3 odometry_information = normal;
        if (pushed && site == 0) odometry_information(2, 2) = extreme;
        const Landmarks::Observation observation =
            seen(truth, pushed && site == 1 ? extreme : 100.0);
        Closure closure{places[std::max(k - 3, 0)], SE2(), normal};
        closure.measurement = graph.estimate(closure.seen).inverse().compose(truth);
        if (pushed && site == 2) closure.information(2, 2) = extreme;
        if (pushed && site == 3) closure.information(0, 0) = extreme;
        const Index closures = k >= 7 ? 1 : 0;
        if (pushed && refused) {
          const Place<SE2> before = graph.current();
          const double chi2 = solver->chi2();
          CompactStepResult r;
          CHECK(graph.addStep(step, odometry_information, &closure, closures, &observation, 1,
                              &r) == Status::InvalidArgument);
          CHECK(samePlace(graph.current(), before));
          CHECK(solver->chi2() == chi2);
          break;  // the rest of this run is the normal one
        }
        CompactStepResult r;
        REQUIRE(graph.addStep(step, odometry_information, &closure, closures, &observation, 1,
                              &r) == Status::Ok);
        if (k <= 8) {  // the twin, in step up to the pushed observation, which it never sees
          Closure twin_closure = closure;
          twin_closure.information = normal;
          REQUIRE(twin.addStep(step, normal, &twin_closure, closures, &observation,
                               pushed && site == 1 ? 0 : 1) == Status::Ok);
        }
        if (pushed && site == 1 && r.localized == 0) {
          CHECK(samePlace(graph.current(), twin.current()));
          ++skipped_corrections;
        }
        places.push_back(graph.current());
        const SE2 now = graph.estimate(graph.current());
        REQUIRE(graph.current().covariance.allFinite());
        REQUIRE(now.translation().allFinite());
        REQUIRE(std::isfinite(now.theta()));
      }
      for (Index node = 0; node < graph.nodes(); ++node) {
        REQUIRE(solver->estimateAt<SE2>(solver->indexOf<SE2>(node)).translation().allFinite());
      }
      REQUIRE(solver->estimateAt<Point2>(solver->indexOf<Point2>(100)).vector().allFinite());
    }
  }
  CHECK(skipped_corrections > 0);
}
