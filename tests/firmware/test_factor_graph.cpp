// FactorGraph<Model> as the mixed-size factorization's source of Lambda and eta, for Slam2D and
// Slam3D: full assembly in random column orders (each factor linearized once, the later
// variable's share through LaterDiagonals) and the change of an update (relinearized variables,
// added factors, a disabled prior), both against a dense J^T Omega J and -J^T Omega e built here
// from central differences of each factor kind's error along each variable's retraction; rollback
// restoring every committed byte; factorChi2 against e^T Omega e; per-kind capacities and the
// value pools.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <type_traits>
#include <utility>
#include <vector>

#include "lslam/graph/factor_graph.h"
#include "lslam/models/model_traits.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

using namespace lslam;

namespace {

constexpr double kStep = 1e-6;  // central differences

template <class Model>
struct ModelTypes;
template <>
struct ModelTypes<Slam2D> {
  using Pose = SE2;
  using Landmark = Point2;
  using PosePrior = PriorSE2Factor;
  using Between = BetweenSE2Factor;
  using LandmarkPrior = PriorPoint2Factor;
};
template <>
struct ModelTypes<Slam3D> {
  using Pose = SE3;
  using Landmark = Point3;
  using PosePrior = PriorSE3Factor;
  using Between = BetweenSE3Factor;
  using LandmarkPrior = PriorPoint3Factor;
};

template <int N>
Eigen::Matrix<double, N, 1> randomVector(std::mt19937& rng, double half_width) {
  std::uniform_real_distribution<double> u(-half_width, half_width);
  Eigen::Matrix<double, N, 1> v;
  for (int i = 0; i < N; ++i) v(i) = u(rng);
  return v;
}

template <int N>
Eigen::Matrix<double, N, N> randomInformation(std::mt19937& rng) {
  const Eigen::Matrix<double, N, N> a = Eigen::Matrix<double, N, N>::NullaryExpr(
      [&]() { return std::uniform_real_distribution<double>(-1.0, 1.0)(rng); });
  const Eigen::Matrix<double, N, N> m = a * a.transpose() + Eigen::Matrix<double, N, N>::Identity();
  return 0.5 * (m + m.transpose());  // exactly symmetric
}

// Rotation matrices from the stored values alone.
Mat2 rotationOf(const SE2& x) {
  Mat2 r;
  r << std::cos(x.theta()), -std::sin(x.theta()), std::sin(x.theta()), std::cos(x.theta());
  return r;
}
Mat3 rotationOf(const SE3& x) {
  return x.rotation().quaternion().toRotationMatrix();
}

// The test's own copy of every variable's point, by variable index.
template <class Model>
struct State {
  using Pose = typename ModelTypes<Model>::Pose;
  using Landmark = typename ModelTypes<Model>::Landmark;
  std::vector<int> kind;
  std::vector<Pose> poses;          // valid where kind == 0
  std::vector<Landmark> landmarks;  // valid where kind == 1

  template <class V>
  const V& get(Index v) const {
    if constexpr (std::is_same_v<V, Pose>) {
      return poses[static_cast<std::size_t>(v)];
    } else {
      return landmarks[static_cast<std::size_t>(v)];
    }
  }
  template <class V>
  V& get(Index v) {
    return const_cast<V&>(static_cast<const State&>(*this).template get<V>(v));
  }
  static int width(int k) { return k == 0 ? Pose::kDof : Landmark::kDof; }
  std::vector<Index> offsets() const {
    std::vector<Index> off(kind.size() + 1, 0);
    for (std::size_t v = 0; v < kind.size(); ++v) off[v + 1] = off[v] + width(kind[v]);
    return off;
  }
};

struct Dense {
  Eigen::MatrixXd lambda;
  Eigen::VectorXd eta;
};

// J^T Omega J and -J^T Omega e of one factor of kind F at the state's points, J by central
// differences of F::error along each variable's retraction.
template <class F, class Model>
void addReference(const State<Model>& s, Index a, Index b, const typename F::Measurement& z,
                  const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>& omega, Dense& d) {
  constexpr int E = F::kErrorDim;
  using A = TypeAtT<0, typename F::Variables>;
  const std::vector<Index> off = s.offsets();
  const A& xa = s.template get<A>(a);
  if constexpr (F::Variables::kSize == 1) {
    const auto err = [&](const A& x) -> Eigen::Matrix<double, E, 1> {
      return F::error(x, z, nullptr);
    };
    Eigen::Matrix<double, E, A::kDof> j;
    for (int k = 0; k < A::kDof; ++k) {
      Eigen::Matrix<double, A::kDof, 1> tau = Eigen::Matrix<double, A::kDof, 1>::Zero();
      tau(k) = kStep;
      j.col(k) = (err(xa.retract(tau)) - err(xa.retract(-tau))) / (2.0 * kStep);
    }
    const Eigen::Matrix<double, E, 1> e = err(xa);
    d.lambda.block(off[a], off[a], A::kDof, A::kDof) += j.transpose() * omega * j;
    d.eta.segment(off[a], A::kDof) -= j.transpose() * omega * e;
  } else {
    using B = TypeAtT<1, typename F::Variables>;
    const B& xb = s.template get<B>(b);
    const auto err = [&](const A& x, const B& y) -> Eigen::Matrix<double, E, 1> {
      return F::error(x, y, z, nullptr, nullptr);
    };
    Eigen::Matrix<double, E, A::kDof + B::kDof> j;
    for (int k = 0; k < A::kDof; ++k) {
      Eigen::Matrix<double, A::kDof, 1> tau = Eigen::Matrix<double, A::kDof, 1>::Zero();
      tau(k) = kStep;
      j.col(k) = (err(xa.retract(tau), xb) - err(xa.retract(-tau), xb)) / (2.0 * kStep);
    }
    for (int k = 0; k < B::kDof; ++k) {
      Eigen::Matrix<double, B::kDof, 1> tau = Eigen::Matrix<double, B::kDof, 1>::Zero();
      tau(k) = kStep;
      j.col(A::kDof + k) = (err(xa, xb.retract(tau)) - err(xa, xb.retract(-tau))) / (2.0 * kStep);
    }
    const Eigen::Matrix<double, E, 1> e = err(xa, xb);
    const Eigen::MatrixXd h = j.transpose() * omega * j;
    const Eigen::VectorXd g = -(j.transpose() * omega * e);
    const Index idx[2] = {a, b};
    const int dof[2] = {A::kDof, B::kDof};
    const int at[2] = {0, A::kDof};
    for (int p = 0; p < 2; ++p) {
      d.eta.segment(off[idx[p]], dof[p]) += g.segment(at[p], dof[p]);
      for (int q = 0; q < 2; ++q)
        d.lambda.block(off[idx[p]], off[idx[q]], dof[p], dof[q]) +=
            h.block(at[p], at[q], dof[p], dof[q]);
    }
  }
}

// e^T Omega e at the state's points.
template <class F, class Model>
double referenceChi2(const State<Model>& s, Index a, Index b, const typename F::Measurement& z,
                     const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>& omega) {
  using A = TypeAtT<0, typename F::Variables>;
  Eigen::Matrix<double, F::kErrorDim, 1> e;
  if constexpr (F::Variables::kSize == 1) {
    e = F::error(s.template get<A>(a), z, nullptr);
  } else {
    using B = TypeAtT<1, typename F::Variables>;
    e = F::error(s.template get<A>(a), s.template get<B>(b), z, nullptr, nullptr);
  }
  return (e.transpose() * omega * e).value();
}

template <class Model>
struct TestFactor {
  Index a = kNoIndex;
  Index b = kNoIndex;
  std::function<void(const State<Model>&, Dense&)> reference;
  std::function<double(const State<Model>&)> chi2;
};

constexpr Index kMaxPoses = 40;
constexpr Index kMaxLandmarks = 30;
constexpr Index kMaxFactors = 200;

template <class Model>
struct Harness {
  using T = ModelTypes<Model>;
  using Pose = typename T::Pose;
  using Landmark = typename T::Landmark;
  using Graph = FactorGraph<Model>;
  using Storage = StaticFactorGraphStorage<Model, kMaxPoses, kMaxLandmarks, kMaxFactors,
                                           kMaxFactors * kFactorValues<typename T::Between>>;

  explicit Harness(unsigned seed) : rng(seed) {}

  std::mt19937 rng;
  std::unique_ptr<Storage> storage = std::make_unique<Storage>();
  FactorGraphArrays arrays = storage->arrays();
  Graph graph{arrays};
  State<Model> state;
  std::vector<TestFactor<Model>> factors;

  Index addPose(const Pose& p) {
    const Index v = graph.addVariable(p);
    REQUIRE(v == static_cast<Index>(state.kind.size()));
    REQUIRE(graph.variableKind(v) == 0);
    state.kind.push_back(0);
    state.poses.push_back(p);
    state.landmarks.emplace_back();
    return v;
  }
  Index addLandmark(const Landmark& l) {
    const Index v = graph.addVariable(l);
    REQUIRE(v == static_cast<Index>(state.kind.size()));
    REQUIRE(graph.variableKind(v) == 1);
    state.kind.push_back(1);
    state.poses.emplace_back();
    state.landmarks.push_back(l);
    return v;
  }
  template <class F>
  Index addFactor(Index a, Index b, const typename F::Measurement& z) {
    const Eigen::Matrix<double, F::kErrorDim, F::kErrorDim> omega =
        randomInformation<F::kErrorDim>(rng);
    REQUIRE(graph.template canAddFactor<F>());
    const Index f = graph.template addFactor<F>(a, b, z, omega);
    REQUIRE(f == static_cast<Index>(factors.size()));
    TestFactor<Model> t;
    t.a = a;
    t.b = b;
    t.reference = [=](const State<Model>& s, Dense& d) { addReference<F>(s, a, b, z, omega, d); };
    t.chi2 = [=](const State<Model>& s) { return referenceChi2<F>(s, a, b, z, omega); };
    factors.push_back(t);
    return f;
  }

  // The dense reference over factors [0, count) except `skip`, at the state's points.
  static Dense reference(const State<Model>& s, const std::vector<TestFactor<Model>>& fs,
                         std::size_t count, Index skip = kNoIndex) {
    const Index n = s.offsets().back();
    Dense d{Eigen::MatrixXd::Zero(n, n), Eigen::VectorXd::Zero(n)};
    for (std::size_t f = 0; f < count; ++f)
      if (static_cast<Index>(f) != skip) fs[f].reference(s, d);
    return d;
  }
  Dense reference(Index skip = kNoIndex) const {
    return reference(state, factors, factors.size(), skip);
  }

  std::set<Index> neighbours(Index v) const {
    std::set<Index> out;
    for (const TestFactor<Model>& f : factors) {
      if (f.b == kNoIndex) continue;
      if (f.a == v) out.insert(f.b);
      if (f.b == v) out.insert(f.a);
    }
    return out;
  }
};

// ---- Measurements near the points, so that no error sits near an angle's cut ----------------

template <class Pose>
Pose perturbed(const Pose& x, std::mt19937& rng, double scale) {
  return x.retract(randomVector<Pose::kDof>(rng, scale));
}

Vec2 pointIn(const SE2& x, const Point2& l) {
  return rotationOf(x).transpose() * (l.vector() - Vec2(x.x(), x.y()));
}
Vec3 pointIn(const SE3& x, const Point3& l) {
  return rotationOf(x).transpose() * (l.vector() - x.translation());
}
Point2 pointFrom(const SE2& x, const Vec2& d) {
  return Point2(Vec2(Vec2(x.x(), x.y()) + rotationOf(x) * d));
}
Point3 pointFrom(const SE3& x, const Vec3& d) {
  return Point3(Vec3(x.translation() + rotationOf(x) * d));
}

// An observation of landmark l from pose p: for Slam2D alternately a position in the robot frame
// and a range and bearing; for Slam3D a position.
void observe(Harness<Slam2D>& h, Index p, Index l, int which) {
  const Vec2 d = pointIn(h.state.poses[p], h.state.landmarks[l]);
  if (which % 2 == 0) {
    h.addFactor<PointObservationSE2Factor>(p, l, d + randomVector<2>(h.rng, 0.05));
  } else {
    const Vec2 z(
        d.norm() + 0.05 * std::uniform_real_distribution<double>(-1, 1)(h.rng),
        std::atan2(d.y(), d.x()) + 0.05 * std::uniform_real_distribution<double>(-1, 1)(h.rng));
    h.addFactor<RangeBearingSE2Factor>(p, l, z);
  }
}
void observe(Harness<Slam3D>& h, Index p, Index l, int /*which*/) {
  const Vec3 d = pointIn(h.state.poses[p], h.state.landmarks[l]);
  h.addFactor<PointObservationSE3Factor>(p, l, d + randomVector<3>(h.rng, 0.05));
}

template <class Model>
typename ModelTypes<Model>::Pose nextPose(Harness<Model>& h,
                                          const typename ModelTypes<Model>::Pose& x) {
  using Pose = typename ModelTypes<Model>::Pose;
  Eigen::Matrix<double, Pose::kDof, 1> step = randomVector<Pose::kDof>(h.rng, 0.4);
  step(0) += 1.0;  // forward
  return x.retract(step);
}

// A landmark placed 1.5 to 3.5 from pose p, observed from p and from one to two other poses at
// least 1 away (the range-bearing Jacobian grows as 1 / distance).
template <class Model>
Index addObservedLandmark(Harness<Model>& h, Index p, const std::vector<Index>& poses, int which) {
  using Landmark = typename ModelTypes<Model>::Landmark;
  auto offset = randomVector<Landmark::kDof>(h.rng, 1.0);
  offset = offset.normalized() * std::uniform_real_distribution<double>(1.5, 3.5)(h.rng);
  const Index l = h.addLandmark(pointFrom(h.state.poses[p], offset));
  observe(h, p, l, which);
  std::vector<Index> candidates;
  for (Index q : poses) {
    if (q != p && pointIn(h.state.poses[q], h.state.landmarks[l]).norm() > 1.0)
      candidates.push_back(q);
  }
  std::shuffle(candidates.begin(), candidates.end(), h.rng);
  const int more = std::uniform_int_distribution<int>(1, 2)(h.rng);
  for (int i = 0; i < more && i < static_cast<int>(candidates.size()); ++i)
    observe(h, candidates[static_cast<std::size_t>(i)], l, which + i + 1);
  return l;
}

// A random graph: a chain of poses (a prior on the first; between factors, some of them
// reversed; a few loop closures), and landmarks observed from several poses, one with a prior.
// Poses and landmarks are interleaved in variable order.
template <class Model>
std::vector<Index> buildGraph(Harness<Model>& h, int num_poses, int num_landmarks) {
  using T = ModelTypes<Model>;
  using Pose = typename T::Pose;
  h.graph.beginUpdate();
  std::vector<Index> poses;
  Pose x = perturbed(Pose(), h.rng, 1.0);
  poses.push_back(h.addPose(x));
  h.template addFactor<typename T::PosePrior>(poses[0], kNoIndex, perturbed(x, h.rng, 0.1));
  int landmarks = 0;
  for (int i = 1; i < num_poses; ++i) {
    const Pose y = nextPose(h, x);
    const Index v = h.addPose(y);
    const Index u = poses.back();
    poses.push_back(v);
    if (i % 3 == 0) {
      h.template addFactor<typename T::Between>(v, u, perturbed(y.between(x), h.rng, 0.1));
    } else {
      h.template addFactor<typename T::Between>(u, v, perturbed(x.between(y), h.rng, 0.1));
    }
    x = y;
    if (landmarks < num_landmarks && i % 2 == 0) {
      addObservedLandmark(h, v, poses, landmarks);
      ++landmarks;
    }
  }
  while (landmarks < num_landmarks) {
    addObservedLandmark(h, poses[static_cast<std::size_t>(landmarks) % poses.size()], poses,
                        landmarks);
    ++landmarks;
  }
  for (int k = 0; k < 3; ++k) {  // loop closures
    std::uniform_int_distribution<std::size_t> pick(0, poses.size() - 1);
    const Index a = poses[pick(h.rng)];
    Index b = poses[pick(h.rng)];
    if (a == b) b = a == poses[0] ? poses[1] : poses[0];
    h.template addFactor<typename T::Between>(
        a, b, perturbed(h.state.poses[a].between(h.state.poses[b]), h.rng, 0.1));
  }
  // A landmark prior on the last landmark.
  Index last = kNoIndex;
  for (Index v = 0; v < static_cast<Index>(h.state.kind.size()); ++v)
    if (h.state.kind[static_cast<std::size_t>(v)] == 1) last = v;
  REQUIRE(last != kNoIndex);
  h.template addFactor<typename T::LandmarkPrior>(last, kNoIndex,
                                                  perturbed(h.state.landmarks[last], h.rng, 0.1));
  h.graph.commit();
  return poses;
}

// ---- The driver: what a factorization asks of its source --------------------------------------

// Every column assembled in the order variable_at (full: assembleColumn, with LaterDiagonals; or
// change: assembleColumnChange), each with a slot for every later position, written back to a
// dense symmetric matrix in variable order. raw receives every block and eta, for exact
// comparisons.
template <class Model>
Dense assemble(const FactorGraph<Model>& graph, const std::vector<Index>& variable_at, bool change,
               std::vector<double>* raw = nullptr) {
  using Sizes = ModelBlockSizes<Model>;
  using Graph = FactorGraph<Model>;
  constexpr int D = Sizes::kMax;
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;
  const Index n = static_cast<Index>(variable_at.size());
  REQUIRE(n == graph.variables());
  std::vector<Index> position(static_cast<std::size_t>(n));
  for (Index k = 0; k < n; ++k) position[variable_at[k]] = k;
  const auto width = [&](Index v) { return Sizes::sizeOfKind(graph.variableKind(v)); };
  std::vector<Index> off(static_cast<std::size_t>(n) + 1, 0);
  for (Index v = 0; v < n; ++v) off[v + 1] = off[v] + width(v);
  Dense d{Eigen::MatrixXd::Zero(off[n], off[n]), Eigen::VectorXd::Zero(off[n])};

  std::vector<Block> diagonal(static_cast<std::size_t>(n), Block::Zero());
  std::vector<Vector> eta(static_cast<std::size_t>(n), Vector::Zero());
  typename Graph::Later later(diagonal.data(), eta.data());
  std::vector<Index> slot_of_row(static_cast<std::size_t>(n), -1);
  for (Index k = 0; k < n; ++k) {
    const Index v = variable_at[k];
    const int w = width(v);
    std::vector<Index> offsets;
    Index total = 0;
    for (Index r = k; r < n; ++r) {
      slot_of_row[r] = r - k;
      offsets.push_back(total);
      total += width(variable_at[r]) * w;
    }
    std::vector<double> values(static_cast<std::size_t>(total), 0.0);
    if (change) {
      eta[k].setZero();
    } else {  // what the earlier columns sent
      Eigen::Map<Eigen::MatrixXd>(values.data(), w, w) = diagonal[k].topLeftCorner(w, w);
    }
    typename Graph::Accumulator acc(values.data(), offsets.data(), slot_of_row.data(), &eta[k]);
    if (change) {
      graph.assembleColumnChange(v, position.data(), acc);
    } else {
      graph.assembleColumn(v, position.data(), acc, later);
    }
    for (Index r = k; r < n; ++r) {
      const Index u = variable_at[r];
      const Eigen::Map<const Eigen::MatrixXd> block(values.data() + offsets[r - k], width(u), w);
      d.lambda.block(off[u], off[v], width(u), w) = block;
      if (u != v) d.lambda.block(off[v], off[u], w, width(u)) = block.transpose();
    }
    for (int i = w; i < D; ++i) REQUIRE(eta[k](i) == 0.0);  // a column uses its top only
    d.eta.segment(off[v], w) = eta[k].head(w);
    if (raw != nullptr) {
      raw->insert(raw->end(), values.begin(), values.end());
      raw->insert(raw->end(), eta[k].data(), eta[k].data() + w);
    }
  }
  return d;
}

std::vector<Index> randomOrder(Index n, std::mt19937& rng) {
  std::vector<Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  return order;
}

std::vector<Index> identityOrder(Index n) {
  std::vector<Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  return order;
}

double scaleOf(const Dense& d) {
  return std::max(1.0, std::max(d.lambda.cwiseAbs().maxCoeff(), d.eta.cwiseAbs().maxCoeff()));
}

double maxError(const Dense& got, const Dense& expected) {
  return std::max((got.lambda - expected.lambda).cwiseAbs().maxCoeff(),
                  (got.eta - expected.eta).cwiseAbs().maxCoeff());
}

double relativeError(const Dense& got, const Dense& expected) {
  return maxError(got, expected) / scaleOf(expected);
}

bool sameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

template <class T>
void appendBytes(std::vector<unsigned char>& out, const T* p, Index count) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(p);
  out.insert(out.end(), bytes, bytes + sizeof(T) * static_cast<std::size_t>(count));
}

// Every committed byte of the graph's arrays (counted from the graph's sizes and the factors'
// arities, computed here), the counts, chi2 and a full assembly's bits.
template <class Model>
std::vector<unsigned char> snapshot(const Harness<Model>& h) {
  using Pose = typename ModelTypes<Model>::Pose;
  using Landmark = typename ModelTypes<Model>::Landmark;
  const FactorGraph<Model>& g = h.graph;
  const FactorGraphArrays& a = h.arrays;
  std::vector<unsigned char> out;
  const Index counts[6] = {g.variables(), g.variablesOfKind(0), g.variablesOfKind(1),
                           g.factors(),   g.factorValuesUsed(), g.freeFactors()};
  appendBytes(out, counts, 6);
  const Index n = g.variables();
  Index values = 0;
  for (Index v = 0; v < n; ++v)
    values += a.variable_kind[v] == 0 ? StoredValue<Pose>::kSize : StoredValue<Landmark>::kSize;
  appendBytes(out, a.variable_kind, n);
  appendBytes(out, a.value_offset, n);
  appendBytes(out, a.first_entry, n);
  appendBytes(out, a.values, values);
  const Index m = g.factors();
  Index entries = 0;
  for (Index f = 0; f < m; ++f) entries += a.second_variable[f] == kNoIndex ? 1 : 2;
  appendBytes(out, a.factor_kind, m);
  appendBytes(out, a.first_variable, m);
  appendBytes(out, a.second_variable, m);
  appendBytes(out, a.factor_offset, m);
  appendBytes(out, a.factor_values, g.factorValuesUsed());
  appendBytes(out, a.entry_factor, entries);
  appendBytes(out, a.next_entry, entries);
  const double chi2 = g.chi2();
  appendBytes(out, &chi2, 1);
  std::vector<double> raw;
  assemble(g, identityOrder(n), false, &raw);
  appendBytes(out, raw.data(), static_cast<Index>(raw.size()));
  return out;
}

// Relinearizes v by a random step (its kind's head of a kMax vector whose tail is noise too), in
// the graph and in the state, and checks the staged point is the retraction, bit for bit.
template <class Model>
void relinearizeRandomly(Harness<Model>& h, Index v, double scale) {
  using Graph = FactorGraph<Model>;
  const typename Graph::Delta delta = randomVector<Graph::kMax>(h.rng, scale);
  h.graph.relinearizeBy(v, delta);
  CHECK(h.graph.isStaged(v));
  const auto check = [&](auto& x) {
    using V = std::decay_t<decltype(x)>;
    x = x.retract(delta.template head<V::kDof>());
    double expected[StoredValue<V>::kSize];
    StoredValue<V>::store(x, expected);
    CHECK(std::memcmp(h.graph.variableValues(v), expected, sizeof(expected)) == 0);
    const V staged = h.graph.template linearizationPoint<V>(v);
    double got[StoredValue<V>::kSize];
    StoredValue<V>::store(staged, got);
    CHECK(std::memcmp(got, expected, sizeof(expected)) == 0);
  };
  if (h.state.kind[static_cast<std::size_t>(v)] == 0) {
    check(h.state.poses[static_cast<std::size_t>(v)]);
  } else {
    check(h.state.landmarks[static_cast<std::size_t>(v)]);
  }
}

// ---- The tests, for both models ---------------------------------------------------------------

// The row update's rows of every factor, multiplied out: sum R R^T and R rhs must be Lambda and
// eta (the row update rotates exactly these rows into L).
template <class Model>
Dense fromWhitenedRows(const FactorGraph<Model>& graph) {
  using Sizes = ModelBlockSizes<Model>;
  using Graph = FactorGraph<Model>;
  const Index n = graph.variables();
  const auto width = [&](Index v) { return Sizes::sizeOfKind(graph.variableKind(v)); };
  std::vector<Index> off(static_cast<std::size_t>(n) + 1, 0);
  for (Index v = 0; v < n; ++v) off[v + 1] = off[v] + width(v);
  std::vector<Index> identity(static_cast<std::size_t>(n));
  for (Index v = 0; v < n; ++v) identity[v] = v;
  Dense d{Eigen::MatrixXd::Zero(off[n], off[n]), Eigen::VectorXd::Zero(off[n])};
  for (Index f = 0; f < graph.factors(); ++f) {
    Index positions[2];
    typename Graph::RowBlock rows[2];
    typename Graph::Delta rhs;
    const Index count = graph.whitenedRows(f, identity.data(), positions, rows, &rhs);
    REQUIRE((count == 1 || count == 2));
    for (Index i = 0; i < count; ++i) {
      const Index v = positions[i];
      d.eta.segment(off[v], width(v)) += rows[i].topRows(width(v)) * rhs;
      for (Index j = 0; j < count; ++j) {
        const Index u = positions[j];
        d.lambda.block(off[v], off[u], width(v), width(u)) +=
            rows[i].topRows(width(v)) * rows[j].topRows(width(u)).transpose();
      }
    }
  }
  return d;
}

template <class Model>
void checkWhitenedRows(unsigned seed) {
  for (int c = 0; c < 6; ++c) {
    CAPTURE(c);
    Harness<Model> h(seed + static_cast<unsigned>(c));
    buildGraph(h, 10 + c, 4 + c);
    CHECK(relativeError(fromWhitenedRows(h.graph), h.reference()) <= 1e-6);
  }
}

TEST_CASE("whitenedRows multiply out to J^T Omega J and -J^T Omega e: Slam2D, Slam3D") {
  checkWhitenedRows<Slam2D>(7201u);
  checkWhitenedRows<Slam3D>(7301u);
}

template <class Model>
void checkFullAssembly(unsigned seed) {
  for (int c = 0; c < 8; ++c) {
    CAPTURE(c);
    Harness<Model> h(seed + static_cast<unsigned>(c));
    buildGraph(h, 10 + c, 4 + c);
    const Dense expected = h.reference();
    const Index n = h.graph.variables();
    std::vector<double> first_raw;
    for (int order = 0; order < 3; ++order) {
      CAPTURE(order);
      const Dense got = assemble(h.graph, randomOrder(n, h.rng), false);
      CHECK(relativeError(got, expected) <= 1e-6);
    }
    // The same order twice: the same bits.
    const std::vector<Index> order = randomOrder(n, h.rng);
    std::vector<double> raw_a;
    std::vector<double> raw_b;
    assemble(h.graph, order, false, &raw_a);
    assemble(h.graph, order, false, &raw_b);
    CHECK(sameBits(raw_a, raw_b));
    // The pattern of Lambda.
    for (Index v = 0; v < n; ++v) {
      struct Collect final : NeighbourVisitor {
        std::set<Index> seen;
        void visit(Index u) override { seen.insert(u); }
      } collect;
      h.graph.visitNeighbours(v, collect);
      CHECK(collect.seen == h.neighbours(v));
    }
  }
}

TEST_CASE("assembleColumn reproduces J^T Omega J and -J^T Omega e in random orders: Slam2D") {
  checkFullAssembly<Slam2D>(7001u);
}

TEST_CASE("assembleColumn reproduces J^T Omega J and -J^T Omega e in random orders: Slam3D") {
  checkFullAssembly<Slam3D>(7101u);
}

template <class Model>
void checkColumnChange(unsigned seed) {
  using T = ModelTypes<Model>;
  for (int c = 0; c < 6; ++c) {
    CAPTURE(c);
    Harness<Model> h(seed + static_cast<unsigned>(c));
    std::vector<Index> poses = buildGraph(h, 10 + c, 5 + c);
    const std::size_t committed = h.factors.size();
    State<Model> old = h.state;

    h.graph.beginUpdate();
    // Relinearize a few committed variables of both kinds.
    const Index n_old = h.graph.variables();
    std::vector<Index> moved = randomOrder(n_old, h.rng);
    moved.resize(3 + static_cast<std::size_t>(c % 3));
    for (Index v : moved) relinearizeRandomly(h, v, 0.05);
    relinearizeRandomly(h, moved[0], 0.05);  // twice: from the staged point
    // A pose (chained, observing an old landmark), a landmark seen from two poses, a prior.
    const Index last = poses.back();
    const typename T::Pose x = nextPose(h, h.state.poses[last]);
    const Index p = h.addPose(x);
    h.template addFactor<typename T::Between>(
        last, p, perturbed(h.state.poses[last].between(x), h.rng, 0.1));
    Index old_landmark = kNoIndex;
    for (Index v = 0; v < n_old; ++v)
      if (h.state.kind[static_cast<std::size_t>(v)] == 1 &&
          pointIn(x, h.state.landmarks[v]).norm() > 1.0)
        old_landmark = v;
    if (old_landmark != kNoIndex) observe(h, p, old_landmark, c);
    poses.push_back(p);
    addObservedLandmark(h, p, poses, c + 1);
    h.template addFactor<typename T::PosePrior>(poses[2], kNoIndex,
                                                perturbed(h.state.poses[poses[2]], h.rng, 0.1));
    relinearizeRandomly(h, p, 0.05);  // an added variable may move too

    // The old reference at the committed points, over the update's variables (zero for the added).
    for (std::size_t v = old.kind.size(); v < h.state.kind.size(); ++v) {
      old.kind.push_back(h.state.kind[v]);
      old.poses.push_back(h.state.poses[v]);
      old.landmarks.push_back(h.state.landmarks[v]);
    }
    const Dense before = Harness<Model>::reference(old, h.factors, committed);
    const Dense after = h.reference();
    const Dense difference{after.lambda - before.lambda, after.eta - before.eta};
    const Index n = h.graph.variables();
    for (int order = 0; order < 2; ++order) {
      CAPTURE(order);
      const Dense got = assemble(h.graph, randomOrder(n, h.rng), true);
      CHECK(maxError(got, difference) <= 1e-6 * scaleOf(after));
    }
    // Inside the update, the full assembly is at the staged points.
    CHECK(relativeError(assemble(h.graph, randomOrder(n, h.rng), false), after) <= 1e-6);
    // A column that no changed factor touches is exactly zero.
    {
      std::set<Index> touched;
      for (std::size_t f = 0; f < h.factors.size(); ++f) {
        const TestFactor<Model>& t = h.factors[f];
        const bool changed =
            f >= committed || h.graph.isStaged(t.a) || (t.b != kNoIndex && h.graph.isStaged(t.b));
        if (!changed) continue;
        touched.insert(t.a);
        if (t.b != kNoIndex) touched.insert(t.b);
      }
      const Dense got = assemble(h.graph, identityOrder(n), true);
      const std::vector<Index> off = h.state.offsets();
      for (Index v = 0; v < n; ++v) {
        if (touched.count(v) != 0) continue;
        const int w = off[v + 1] - off[v];
        CHECK(got.lambda.middleCols(off[v], w).cwiseAbs().maxCoeff() == 0.0);
        CHECK(got.eta.segment(off[v], w).cwiseAbs().maxCoeff() == 0.0);
      }
    }
    h.graph.commit();
    // The committed points are the staged ones; a quiet update changes nothing.
    for (Index v = 0; v < n; ++v) {
      const auto check = [&](const auto& value) {
        using V = std::decay_t<decltype(value)>;
        double expected[StoredValue<V>::kSize];
        StoredValue<V>::store(value, expected);
        CHECK(std::memcmp(h.graph.variableValues(v), expected, sizeof(expected)) == 0);
      };
      if (h.state.kind[static_cast<std::size_t>(v)] == 0) {
        check(h.state.poses[static_cast<std::size_t>(v)]);
      } else {
        check(h.state.landmarks[static_cast<std::size_t>(v)]);
      }
    }
    CHECK(relativeError(assemble(h.graph, randomOrder(n, h.rng), false), after) <= 1e-6);
    h.graph.beginUpdate();
    const Dense quiet = assemble(h.graph, randomOrder(n, h.rng), true);
    CHECK(quiet.lambda.cwiseAbs().maxCoeff() == 0.0);
    CHECK(quiet.eta.cwiseAbs().maxCoeff() == 0.0);
    h.graph.rollback();
  }
}

TEST_CASE("assembleColumnChange equals the dense difference: Slam2D") {
  checkColumnChange<Slam2D>(7201u);
}

TEST_CASE("assembleColumnChange equals the dense difference: Slam3D") {
  checkColumnChange<Slam3D>(7301u);
}

template <class Model>
void checkRollbackAndDisable(unsigned seed) {
  using T = ModelTypes<Model>;
  for (int c = 0; c < 4; ++c) {
    CAPTURE(c);
    Harness<Model> h(seed + static_cast<unsigned>(c));
    std::vector<Index> poses = buildGraph(h, 9 + c, 4 + c);
    const Index n = h.graph.variables();
    const std::vector<unsigned char> before = snapshot(h);
    const State<Model> state_before = h.state;
    const std::size_t factors_before = h.factors.size();

    // An update that touches everything, then rolled back.
    h.graph.beginUpdate();
    for (Index v : randomOrder(n, h.rng)) relinearizeRandomly(h, v, 0.05);
    h.graph.disablePrior(0);  // the pose prior of buildGraph
    CHECK(h.graph.factorChi2(0) == 0.0);
    const Index p = h.addPose(nextPose(h, h.state.poses[poses.back()]));
    h.template addFactor<typename T::Between>(
        poses.back(), p,
        perturbed(h.state.poses[poses.back()].between(h.state.poses[p]), h.rng, 0.1));
    poses.push_back(p);
    addObservedLandmark(h, p, poses, c);
    // Factors whose second variable is an old one: a loop closure, an old landmark seen again.
    h.template addFactor<typename T::Between>(
        poses[0], poses[2],
        perturbed(h.state.poses[poses[0]].between(h.state.poses[poses[2]]), h.rng, 0.1));
    for (Index v = 0; v < n; ++v) {
      if (h.state.kind[static_cast<std::size_t>(v)] == 1 &&
          pointIn(h.state.poses[p], h.state.landmarks[v]).norm() > 1.0) {
        observe(h, p, v, c);
        break;
      }
    }
    h.template addFactor<typename T::PosePrior>(p, kNoIndex,
                                                perturbed(h.state.poses[p], h.rng, 0.1));
    CHECK(h.graph.variables() > n);
    h.graph.rollback();
    CHECK(snapshot(h) == before);
    h.state = state_before;
    h.factors.resize(factors_before);
    poses.pop_back();

    // Unstaging forgets the points but keeps the added variables and factors.
    h.graph.beginUpdate();
    const Index moved = poses[1];
    const std::vector<double> point_before(
        h.graph.variableValues(moved),
        h.graph.variableValues(moved) + StoredValue<typename T::Pose>::kSize);
    State<Model> staged_state = h.state;
    std::swap(h.state, staged_state);
    relinearizeRandomly(h, moved, 0.1);
    std::swap(h.state, staged_state);
    h.graph.unstageRelinearization();
    CHECK(!h.graph.isStaged(moved));
    CHECK(sameBits(point_before,
                   std::vector<double>(h.graph.variableValues(moved),
                                       h.graph.variableValues(moved) + point_before.size())));
    h.graph.rollback();
    CHECK(snapshot(h) == before);

    // The disabled prior: no share in Lambda, eta or chi2; the change subtracts its old share;
    // a rollback restores its information bit for bit, a commit keeps it out.
    const auto information_before = h.graph.template information<typename T::PosePrior>(0);
    h.graph.beginUpdate();
    h.graph.disablePrior(0);
    CHECK(h.graph.template information<typename T::PosePrior>(0).cwiseAbs().maxCoeff() == 0.0);
    CHECK(h.graph.factorChi2(0) == 0.0);
    const Dense without = h.reference(0);
    CHECK(relativeError(assemble(h.graph, randomOrder(n, h.rng), false), without) <= 1e-6);
    const Dense with = h.reference();
    const Dense removed{without.lambda - with.lambda, without.eta - with.eta};
    const Dense change = assemble(h.graph, randomOrder(n, h.rng), true);
    CHECK(maxError(change, removed) <= 1e-6 * scaleOf(with));
    CHECK(change.lambda.cwiseAbs().maxCoeff() > 0.0);
    h.graph.rollback();
    CHECK(snapshot(h) == before);
    const auto information_after = h.graph.template information<typename T::PosePrior>(0);
    CHECK(std::memcmp(information_after.data(), information_before.data(),
                      sizeof(information_before)) == 0);

    h.graph.beginUpdate();
    h.graph.disablePrior(0);
    h.graph.commit();
    CHECK(h.graph.factorChi2(0) == 0.0);
    CHECK(relativeError(assemble(h.graph, randomOrder(n, h.rng), false), without) <= 1e-6);
    // Committed, it is no longer part of any change.
    h.graph.beginUpdate();
    CHECK(assemble(h.graph, identityOrder(n), true).lambda.cwiseAbs().maxCoeff() == 0.0);
    h.graph.rollback();
  }
}

TEST_CASE("rollback restores every committed byte; disablePrior: Slam2D") {
  checkRollbackAndDisable<Slam2D>(7401u);
}

TEST_CASE("rollback restores every committed byte; disablePrior: Slam3D") {
  checkRollbackAndDisable<Slam3D>(7501u);
}

template <class Model>
void checkChi2(unsigned seed) {
  Harness<Model> h(seed);
  buildGraph(h, 12, 6);
  double sum = 0.0;
  for (std::size_t f = 0; f < h.factors.size(); ++f) {
    CAPTURE(f);
    const double expected = h.factors[f].chi2(h.state);
    const double got = h.graph.factorChi2(static_cast<Index>(f));
    CHECK(expected > 0.0);
    CHECK(std::abs(got - expected) <= 1e-12 * std::max(1.0, expected));
    sum += expected;
  }
  CHECK(std::abs(h.graph.chi2() - sum) <= 1e-12 * std::max(1.0, sum));
  // At staged points inside an update.
  h.graph.beginUpdate();
  relinearizeRandomly(h, 1, 0.2);
  for (std::size_t f = 0; f < h.factors.size(); ++f) {
    const double expected = h.factors[f].chi2(h.state);
    CHECK(std::abs(h.graph.factorChi2(static_cast<Index>(f)) - expected) <=
          1e-12 * std::max(1.0, expected));
  }
  h.graph.rollback();
}

TEST_CASE("factorChi2 is e^T Omega e") {
  checkChi2<Slam2D>(7601u);
  checkChi2<Slam3D>(7701u);
}

TEST_CASE("values and measurements are stored and read back bit for bit; information symmetric") {
  std::mt19937 rng(7801u);
  Harness<Slam3D> h(7802u);
  h.graph.beginUpdate();
  const SE3 x = perturbed(SE3(), rng, 3.0);
  const Index a = h.addPose(x);
  const Index b = h.addPose(perturbed(x, rng, 1.0));
  Mat6 omega = randomInformation<6>(rng);
  omega(4, 1) += 1e-12 * omega(4, 1);  // symmetric to rounding only
  const SE3 z = perturbed(SE3(), rng, 1.0);
  const Index f = h.graph.addFactor<BetweenSE3Factor>(a, b, z, omega);
  h.graph.commit();
  const SE3 got = h.graph.linearizationPoint<SE3>(a);
  CHECK(std::memcmp(got.rotation().quaternion().coeffs().data(),
                    x.rotation().quaternion().coeffs().data(), 4 * sizeof(double)) == 0);
  CHECK(std::memcmp(got.translation().data(), x.translation().data(), 3 * sizeof(double)) == 0);
  const SE3 zz = h.graph.measurement<BetweenSE3Factor>(f);
  CHECK(std::memcmp(zz.rotation().quaternion().coeffs().data(),
                    z.rotation().quaternion().coeffs().data(), 4 * sizeof(double)) == 0);
  const Mat6 stored = h.graph.information<BetweenSE3Factor>(f);
  CHECK((stored == stored.transpose()));
  CHECK(stored(4, 1) == 0.5 * omega(4, 1) + 0.5 * omega(1, 4));
  CHECK(stored(0, 0) == omega(0, 0));
  CHECK(h.graph.factorValuesUsed() == 7 + 36);
  CHECK(kFactorValues<PointObservationSE3Factor> == 3 + 9);

  // SE2 at the angle cut, and a range-bearing measurement.
  Harness<Slam2D> g(7803u);
  g.graph.beginUpdate();
  const SE2 p(1.5, -2.25, 3.14159265358979);
  const Index v = g.addPose(p);
  const Index l = g.addLandmark(Point2(4.0, 1.0));
  const Index r =
      g.graph.addFactor<RangeBearingSE2Factor>(v, l, Vec2(2.5, -0.75), Mat2::Identity());
  g.graph.commit();
  const SE2 q = g.graph.linearizationPoint<SE2>(v);
  CHECK(q.x() == p.x());
  CHECK(q.y() == p.y());
  CHECK(q.theta() == p.theta());
  CHECK((g.graph.linearizationPoint<Point2>(l).vector() == Vec2(4.0, 1.0)));
  CHECK((g.graph.measurement<RangeBearingSE2Factor>(r) == Vec2(2.5, -0.75)));
  CHECK(g.graph.factorKind(r) == kFactorKind<Slam2D, RangeBearingSE2Factor>);
  CHECK(g.graph.variableKinds()[l] == 1);
  // The estimate: the retraction of the solution.
  Eigen::Matrix<double, 3, 1> delta(0.1, -0.2, 0.3);
  const SE2 e = g.graph.estimate<SE2>(v, delta);
  const SE2 expected = p.retract(delta);
  CHECK(e.x() == expected.x());
  CHECK(e.theta() == expected.theta());
  const Point2 el = g.graph.estimate<Point2>(l, delta);
  CHECK((el.vector() == Vec2(Vec2(4.0, 1.0) + delta.head<2>())));
  int count = 0;
  g.graph.forEachFactor(l, [&](Index factor) {
    CHECK(factor == r);
    ++count;
  });
  CHECK(count == 1);
}

// Every stored value of the graph, in the test's order of adding.
template <class Storage, class Model>
void checkCapacities() {
  using T = ModelTypes<Model>;
  using Pose = typename T::Pose;
  using Landmark = typename T::Landmark;
  auto storage = std::make_unique<Storage>();
  const FactorGraphArrays arrays = storage->arrays();
  FactorGraph<Model> graph(arrays);
  std::mt19937 rng(7901u);
  graph.beginUpdate();
  std::vector<std::vector<double>> written;
  // Interleaved kinds until both are full: each add is allowed by the query, and after the last
  // of a kind the query says no.
  while (graph.template canAddVariable<Pose>() || graph.template canAddVariable<Landmark>()) {
    const bool pose = graph.template canAddVariable<Pose>() &&
                      (!graph.template canAddVariable<Landmark>() || rng() % 2 == 0);
    std::vector<double> values;
    if (pose) {
      const Pose x = perturbed(Pose(), rng, 2.0);
      graph.addVariable(x);
      values.resize(StoredValue<Pose>::kSize);
      StoredValue<Pose>::store(x, values.data());
    } else {
      const Landmark x(randomVector<Landmark::kDof>(rng, 5.0));
      graph.addVariable(x);
      values.resize(StoredValue<Landmark>::kSize);
      StoredValue<Landmark>::store(x, values.data());
    }
    written.push_back(values);
  }
  CHECK(graph.variablesOfKind(0) == graph.maxVariablesOfKind(0));
  CHECK(graph.variablesOfKind(1) == graph.maxVariablesOfKind(1));
  CHECK(graph.freeVariablesOfKind(0) == 0);
  CHECK(graph.freeVariablesOfKind(1) == 0);
  CHECK(graph.variables() == arrays.max_variables);
  // The value pool is exactly full and no value overwrote another.
  Index used = 0;
  for (Index v = 0; v < graph.variables(); ++v) {
    CHECK(arrays.value_offset[v] == used);
    used += static_cast<Index>(written[static_cast<std::size_t>(v)].size());
    CHECK(sameBits(written[static_cast<std::size_t>(v)],
                   std::vector<double>(
                       graph.variableValues(v),
                       graph.variableValues(v) + written[static_cast<std::size_t>(v)].size())));
  }
  CHECK(used == arrays.max_values);

  // Factors until the value pool is too short for a between factor: then a landmark prior (fewer
  // values) still fits, until the pool or the factor count runs out.
  Index pose_a = kNoIndex;
  Index pose_b = kNoIndex;
  Index landmark = kNoIndex;
  for (Index v = 0; v < graph.variables(); ++v) {
    if (graph.variableKind(v) == 0) (pose_a == kNoIndex ? pose_a : pose_b) = v;
    if (graph.variableKind(v) == 1) landmark = v;
  }
  using Between = typename T::Between;
  using LandmarkPrior = typename T::LandmarkPrior;
  while (graph.template canAddFactor<Between>()) {
    graph.template addFactor<Between>(
        pose_a, pose_b, Pose(),
        Eigen::Matrix<double, Between::kErrorDim, Between::kErrorDim>::Identity());
  }
  CHECK((graph.freeFactors() == 0 || graph.freeFactorValues() < kFactorValues<Between>));
  while (graph.template canAddFactor<LandmarkPrior>()) {
    graph.template addFactor<LandmarkPrior>(
        landmark, kNoIndex, Landmark(),
        Eigen::Matrix<double, LandmarkPrior::kErrorDim, LandmarkPrior::kErrorDim>::Identity());
  }
  CHECK((graph.freeFactors() == 0 || graph.freeFactorValues() < kFactorValues<LandmarkPrior>));
  CHECK(graph.factorValuesUsed() + graph.freeFactorValues() == graph.maxFactorValues());
  const Index factors = graph.factors();
  const Index values_used = graph.factorValuesUsed();
  CHECK(!graph.template canAddFactor<Between>());
  CHECK(!graph.template canAddVariable<Pose>());
  CHECK(graph.factors() == factors);
  CHECK(graph.factorValuesUsed() == values_used);
  graph.commit();
  // A rollback returns the capacity of what it forgets.
  graph.beginUpdate();
  graph.rollback();
  CHECK(graph.freeVariablesOfKind(0) == 0);
  CHECK(FactorGraph<Model>::factorValuesOfKind(kFactorKind<Model, Between>) ==
        kFactorValues<Between>);
  CHECK(FactorGraph<Model>::arityOfKind(kFactorKind<Model, LandmarkPrior>) == 1);
}

TEST_CASE("per-kind capacities and exactly sized value pools") {
  // Slam2D: 3 doubles per pose, 2 per landmark; between 3 + 9, landmark prior 2 + 4.
  using Storage2D = StaticFactorGraphStorage<Slam2D, 3, 2, 8, 2 * 12 + 6 * 3 + 5>;
  static_assert(Storage2D::kValues == 3 * 3 + 2 * 2);
  static_assert(Storage2D::kMaxVariables == 5);
  checkCapacities<Storage2D, Slam2D>();
  // Slam3D: 7 per pose, 3 per landmark; between 7 + 36, landmark prior 3 + 9.
  using Storage3D = StaticFactorGraphStorage<Slam3D, 4, 3, 4, 3 * 43 + 20>;
  static_assert(Storage3D::kValues == 4 * 7 + 3 * 3);
  checkCapacities<Storage3D, Slam3D>();
  // The factor count as the limit.
  using Few = StaticFactorGraphStorage<Slam2D, 2, 1, 2, 1000>;
  checkCapacities<Few, Slam2D>();
}

}  // namespace
