// The incremental block Cholesky at mixed block sizes (<3, 2>: 2D poses and points; <6, 3>: 3D
// poses and points) against Eigen's dense LLT of the same matrix, over random growth sequences
// with random variable kinds (fixed seeds): the recomputing update, full refactorizations in
// random orders, the reordered top, rejections, compaction and layout, full and partial solves.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "lslam/linear/incremental_cholesky.h"

namespace {

using lslam::Index;
using lslam::Status;

constexpr Index kMaxColumns = 60;
constexpr Index kMaxBlocks = 6000;
constexpr Index kMaxValues = kMaxBlocks * 18;

// A symmetric matrix over variables of mixed sizes, held densely in variable order, with its
// block pattern: the factorization's source.
template <int... S>
class MixedSource final : public lslam::InformationSource<S...> {
 public:
  using Sizes = lslam::BlockSizes<S...>;

  Index size() const { return static_cast<Index>(kind.size()); }
  int width(Index v) const { return Sizes::sizeOfKind(kind[static_cast<std::size_t>(v)]); }
  Index offset(Index v) const { return offsets[static_cast<std::size_t>(v)]; }
  Index dimension() const { return static_cast<Index>(lambda.rows()); }

  void addVariable(std::uint8_t k) {
    const Index n = dimension();
    const int w = Sizes::sizeOfKind(k);
    kind.push_back(k);
    offsets.push_back(n);
    neighbours.emplace_back();
    for (Eigen::MatrixXd* m : {&lambda, &committed_lambda}) {
      Eigen::MatrixXd grown = Eigen::MatrixXd::Zero(n + w, n + w);
      grown.topLeftCorner(n, n) = *m;
      *m = grown;
    }
    for (Eigen::VectorXd* e : {&eta, &committed_eta}) {
      Eigen::VectorXd grown = Eigen::VectorXd::Zero(n + w);
      grown.head(n) = *e;
      *e = grown;
    }
  }
  // J^T J and J^T e of a random factor on (a, b) (b == a: unary), m rows, with a diagonal boost so
  // that chains of factors stay well conditioned.
  void addFactor(Index a, Index b, std::mt19937& rng) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const Index vars[2] = {a, b};
    const int count = a == b ? 1 : 2;
    const int m = width(b);
    int cols = 0;
    for (int i = 0; i < count; ++i) cols += width(vars[i]);
    Eigen::MatrixXd j(m, cols);
    for (int r = 0; r < m; ++r) {
      for (int c = 0; c < cols; ++c) j(r, c) = u(rng);
    }
    int c0 = 0;
    for (int i = 0; i < count; ++i) {
      for (int r = 0; r < std::min(m, width(vars[i])); ++r) j(r, c0 + r) += 3.0;
      c0 += width(vars[i]);
    }
    Eigen::VectorXd e(m);
    for (int r = 0; r < m; ++r) e(r) = u(rng);
    const Eigen::MatrixXd h = j.transpose() * j;
    const Eigen::VectorXd g = j.transpose() * e;
    int pi = 0;
    for (int p = 0; p < count; ++p) {
      int qi = 0;
      for (int q = 0; q < count; ++q) {
        lambda.block(offset(vars[p]), offset(vars[q]), width(vars[p]), width(vars[q])) +=
            h.block(pi, qi, width(vars[p]), width(vars[q]));
        qi += width(vars[q]);
      }
      eta.segment(offset(vars[p]), width(vars[p])) += g.segment(pi, width(vars[p]));
      pi += width(vars[p]);
    }
    neighbours[static_cast<std::size_t>(a)].insert(b);
    neighbours[static_cast<std::size_t>(b)].insert(a);
  }

  // A factor given as its whitened rows (the row update's form): rows_t[i] holds A_i^T in its
  // top-left width(vars[i]) x m corner, b its first m entries; Lambda += A^T A, eta += A^T b.
  template <class Block, class Vector>
  void addRows(const std::vector<Index>& vars, const std::vector<Block>& rows_t, const Vector& b,
               int m) {
    for (std::size_t p = 0; p < vars.size(); ++p) {
      const Index vp = vars[p];
      const Eigen::MatrixXd ap = rows_t[p].topLeftCorner(width(vp), m);
      for (std::size_t q = 0; q < vars.size(); ++q) {
        const Index vq = vars[q];
        lambda.block(offset(vp), offset(vq), width(vp), width(vq)) +=
            ap * rows_t[q].topLeftCorner(width(vq), m).transpose();
      }
      eta.segment(offset(vp), width(vp)) += ap * b.head(m);
      for (Index vq : vars) neighbours[static_cast<std::size_t>(vp)].insert(vq);
    }
  }

  void visitNeighbours(Index v, lslam::NeighbourVisitor& visitor) const override {
    for (Index u : neighbours[static_cast<std::size_t>(v)]) {
      if (u != v) visitor.visit(u);
    }
  }
  void assembleColumn(Index v, const Index* position, lslam::ColumnAccumulator<S...>& acc,
                      lslam::LaterDiagonals<S...>& /*later*/) const override {
    add(v, position, acc, lambda, eta);
  }
  void assembleColumnChange(Index v, const Index* position,
                            lslam::ColumnAccumulator<S...>& acc) const override {
    add(v, position, acc, lambda - committed_lambda, eta - committed_eta);
  }
  void commit() {
    committed_lambda = lambda;
    committed_eta = eta;
  }
  void revert() {
    lambda = committed_lambda;
    eta = committed_eta;
  }

  std::vector<std::uint8_t> kind;  // per variable: the index into S...
  std::vector<Index> offsets;
  std::vector<std::set<Index>> neighbours;
  Eigen::MatrixXd lambda, committed_lambda;
  Eigen::VectorXd eta, committed_eta;

 private:
  void add(Index v, const Index* position, lslam::ColumnAccumulator<S...>& acc,
           const Eigen::MatrixXd& l, const Eigen::VectorXd& e) const {
    acc.addDiagonal(l.block(offset(v), offset(v), width(v), width(v)));
    acc.addEta(e.segment(offset(v), width(v)));
    for (Index u : neighbours[static_cast<std::size_t>(v)]) {
      if (u != v && position[u] > position[v])
        acc.addBelow(position[u], l.block(offset(u), offset(v), width(u), width(v)));
    }
  }
};

template <int... S>
struct Harness {
  using Chol = lslam::IncrementalCholesky<S...>;
  using Storage =
      lslam::StaticCholeskyStorageFor<lslam::BlockSizes<S...>, kMaxColumns, kMaxBlocks, kMaxValues>;
  static lslam::CholeskyArrays<S...> arraysOf(Storage& s, const std::uint8_t* kinds) {
    lslam::CholeskyArrays<S...> a = s.arrays();
    a.variable_kind = kinds;
    return a;
  }
  Harness() : chol(arraysOf(storage, kinds)) {}

  Storage storage;
  std::uint8_t kinds[kMaxColumns] = {};
  Chol chol;
  MixedSource<S...> source;
  std::vector<Index> variable_at, position_of;
  std::vector<typename Chol::Vector> delta;  // the solution per variable, kept across solves

  // Adds a variable of a random kind at the last position.
  Index addVariable(std::mt19937& rng) {
    const Index v = source.size();
    const auto k = static_cast<std::uint8_t>(std::uniform_int_distribution<int>(0, 3)(rng) == 0);
    kinds[v] = k;
    source.addVariable(k);
    variable_at.push_back(v);
    position_of.push_back(v);
    delta.push_back(Chol::Vector::Zero());
    return v;
  }

  // P Lambda P^T and P eta in position order.
  std::vector<Index> positionOffsets() const {
    std::vector<Index> off(variable_at.size() + 1, 0);
    for (std::size_t k = 0; k < variable_at.size(); ++k)
      off[k + 1] = off[k] + source.width(variable_at[k]);
    return off;
  }
  Eigen::MatrixXd permuted(const Eigen::MatrixXd& m, const std::vector<Index>& off) const {
    Eigen::MatrixXd p(m.rows(), m.cols());
    for (std::size_t r = 0; r < variable_at.size(); ++r) {
      for (std::size_t c = 0; c < variable_at.size(); ++c) {
        const Index vr = variable_at[r];
        const Index vc = variable_at[c];
        p.block(off[r], off[c], source.width(vr), source.width(vc)) =
            m.block(source.offset(vr), source.offset(vc), source.width(vr), source.width(vc));
      }
    }
    return p;
  }

  // The factor's L and d, dense in position order (the pool holds L(k,k)^-1).
  void denseFactor(Eigen::MatrixXd& l, Eigen::VectorXd& d) const {
    const std::vector<Index> off = positionOffsets();
    const Index n = off.back();
    l = Eigen::MatrixXd::Zero(n, n);
    d = Eigen::VectorXd::Zero(n);
    for (Index k = 0; k < chol.columns(); ++k) {
      const int w = chol.columnWidth(k);
      REQUIRE(w == source.width(variable_at[static_cast<std::size_t>(k)]));
      const Index* rows = chol.columnRows(k);
      for (Index i = 0; i < chol.columnSize(k); ++i) {
        const int h = source.width(variable_at[static_cast<std::size_t>(rows[i])]);
        const Eigen::Map<const Eigen::MatrixXd> block(chol.blockValues(k, i), h, w);
        if (i == 0) {
          l.block(off[k], off[k], w, w) = Eigen::MatrixXd(block).inverse();
        } else {
          l.block(off[rows[i]], off[k], h, w) = block;
        }
      }
      d.segment(off[k], w) = chol.rhs(k).head(w);
    }
  }

  void checkAgainstDense() const {
    const std::vector<Index> off = positionOffsets();
    const Eigen::MatrixXd p_lambda = permuted(source.committed_lambda, off);
    Eigen::VectorXd p_eta(off.back());
    for (std::size_t k = 0; k < variable_at.size(); ++k)
      p_eta.segment(off[k], source.width(variable_at[k])) =
          source.committed_eta.segment(source.offset(variable_at[k]), source.width(variable_at[k]));
    Eigen::MatrixXd l;
    Eigen::VectorXd d;
    denseFactor(l, d);
    const Eigen::MatrixXd expected = Eigen::LLT<Eigen::MatrixXd>(p_lambda).matrixL();
    const double scale = std::max(1.0, p_lambda.cwiseAbs().maxCoeff());
    CHECK((l - expected).cwiseAbs().maxCoeff() <= 1e-9 * scale);
    const Eigen::VectorXd expected_d = expected.triangularView<Eigen::Lower>().solve(p_eta);
    CHECK((d - expected_d).cwiseAbs().maxCoeff() <= 1e-9 * std::max(1.0, p_eta.norm()));
  }

  // Every committed column's rows, values and right-hand side, for bit-for-bit comparisons.
  std::vector<double> snapshot() const {
    std::vector<double> out;
    for (Index k = 0; k < chol.columns(); ++k) {
      const int w = chol.columnWidth(k);
      for (Index i = 0; i < chol.columnSize(k); ++i) {
        const Index row = chol.columnRows(k)[i];
        out.push_back(static_cast<double>(row));
        const int h = source.width(variable_at[static_cast<std::size_t>(row)]);
        out.insert(out.end(), chol.blockValues(k, i), chol.blockValues(k, i) + h * w);
      }
      for (int r = 0; r < w; ++r) out.push_back(chol.rhs(k)(r));
    }
    return out;
  }

  // Dense solution of Lambda x = eta per variable, against the factor's back-substitution.
  void checkSolve(bool full) {
    std::vector<Index> visited(variable_at.size());
    chol.backSubstitute(delta.data(), variable_at.data(), full ? 0.0 : 1e-12, full, visited.data());
    const Eigen::VectorXd x = source.committed_lambda.llt().solve(source.committed_eta);
    for (Index v = 0; v < source.size(); ++v) {
      const int w = source.width(v);
      CHECK((delta[static_cast<std::size_t>(v)].head(w) - x.segment(source.offset(v), w))
                .cwiseAbs()
                .maxCoeff() <= 1e-8 * std::max(1.0, x.cwiseAbs().maxCoeff()));
      if (w < Chol::D) CHECK(delta[static_cast<std::size_t>(v)].tail(Chol::D - w).isZero());
    }
  }

  // One step: a variable tied to the last one and, sometimes, to a random earlier one; a unary
  // factor now and then. Returns the variables whose columns changed.
  std::vector<Index> grow(std::mt19937& rng) {
    const Index v = addVariable(rng);
    std::vector<Index> touched = {v};
    if (v == 0) {
      source.addFactor(v, v, rng);
      return touched;
    }
    source.addFactor(v - 1, v, rng);
    touched.push_back(v - 1);
    if (v > 3 && std::uniform_int_distribution<int>(0, 2)(rng) == 0) {
      const Index old = std::uniform_int_distribution<Index>(0, v - 2)(rng);
      source.addFactor(old, v, rng);
      touched.push_back(old);
    }
    if (std::uniform_int_distribution<int>(0, 4)(rng) == 0) {
      const Index u = std::uniform_int_distribution<Index>(0, v)(rng);
      source.addFactor(u, u, rng);
      touched.push_back(u);
    }
    return touched;
  }
};

template <int... S>
void runGrowth(unsigned seed) {
  CAPTURE(seed);
  std::mt19937 rng(seed);
  auto h = std::make_unique<Harness<S...>>();
  for (Index step = 0; step < 45; ++step) {
    const std::vector<Index> touched = h->grow(rng);
    bool reordered = false;
    const int path = std::uniform_int_distribution<int>(0, 5)(rng);
    if (path == 0 && step > 2) {
      // A full refactorization in a random order.
      std::shuffle(h->variable_at.begin(), h->variable_at.end(), rng);
      for (std::size_t k = 0; k < h->variable_at.size(); ++k)
        h->position_of[static_cast<std::size_t>(h->variable_at[k])] = static_cast<Index>(k);
      h->chol.beginUpdate(1, true);
      reordered = true;
    } else {
      h->chol.beginUpdate(1, false);
      for (Index v : touched) h->chol.markChanged(h->position_of[static_cast<std::size_t>(v)]);
    }
    REQUIRE(h->chol.factorize(h->source, h->variable_at.data(), h->position_of.data()) ==
            Status::Ok);
    h->chol.commit();
    h->source.commit();
    h->checkAgainstDense();
    if (step % 7 == 3) h->chol.compact();
    // As the solver does: the solve's copy of x follows the variables to their positions.
    if (reordered) h->chol.loadSolution(h->delta.data(), h->variable_at.data());
    h->checkSolve(step % 2 == 0);
  }
}

TEST_CASE("mixed block sizes: the recomputing update and full refactorizations equal dense LLT") {
  for (unsigned seed = 1; seed <= 12; ++seed) runGrowth<3, 2>(seed);
  for (unsigned seed = 1; seed <= 6; ++seed) runGrowth<6, 3>(seed);
}

template <int... S>
void runReordered(unsigned seed) {
  CAPTURE(seed);
  using ColamdStorage =
      lslam::StaticColamdStorage<kMaxColumns * kMaxColumns, kMaxColumns, kMaxColumns>;
  std::mt19937 rng(seed);
  auto h = std::make_unique<Harness<S...>>();
  auto colamd = std::make_unique<ColamdStorage>();
  lslam::ColamdOrdering ordering(colamd->arrays());
  for (Index step = 0; step < 40; ++step) {
    const std::vector<Index> touched = h->grow(rng);
    const Index v = h->source.size() - 1;
    h->chol.beginUpdate(1, false);
    for (Index t : touched) h->chol.markChanged(h->position_of[static_cast<std::size_t>(t)]);
    if (step < 3) {
      REQUIRE(h->chol.factorize(h->source, h->variable_at.data(), h->position_of.data()) ==
              Status::Ok);
      h->chol.commit();
    } else {
      std::set<Index> old_last;
      for (Index t : touched) {
        if (t != v) old_last.insert(h->position_of[static_cast<std::size_t>(t)]);
      }
      std::vector<Index> last(old_last.begin(), old_last.end());
      last.push_back(h->position_of[static_cast<std::size_t>(v)]);
      std::vector<Index> new_variable_at(h->variable_at.size());
      std::vector<Index> new_position_of(h->position_of.size());
      REQUIRE(h->chol.affectedTopSize() >= 1);
      REQUIRE(h->chol.factorizeReordered(h->source, ordering, last.data(),
                                         static_cast<Index>(last.size()), h->variable_at.data(),
                                         new_variable_at.data(),
                                         new_position_of.data()) == Status::Ok);
      h->chol.commit();
      h->variable_at = new_variable_at;
      h->position_of = new_position_of;
      CHECK(h->variable_at.back() == v);  // the added variable stays last
    }
    h->source.commit();
    h->checkAgainstDense();
    // The solve's copy of x follows the moved positions (as the solver does after a reorder).
    h->chol.loadSolution(h->delta.data(), h->variable_at.data());
    h->checkSolve(step % 2 == 0);
  }
}

TEST_CASE("mixed block sizes: the reordered update of the affected top equals dense LLT") {
  for (unsigned seed = 100; seed < 110; ++seed) runReordered<3, 2>(seed);
  for (unsigned seed = 100; seed < 105; ++seed) runReordered<6, 3>(seed);
}

// Row updates at mixed sizes: each step adds a variable of a random kind and factors given as
// whitened rows (random error sizes among the model's, so a factor's rows are often narrower than
// the widest block), one at a time or two together, on the added column and on random older ones
// (loop closures into the grown factor); recomputing updates and compactions in between. The
// factor must equal the dense LLT of the accumulated A^T A, and the solve its dense solution.
template <int... S>
void runRowUpdates(unsigned seed) {
  CAPTURE(seed);
  using Chol = lslam::IncrementalCholesky<S...>;
  using Block = typename Chol::Block;
  using Vector = typename Chol::Vector;
  using Sizes = lslam::BlockSizes<S...>;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto h = std::make_unique<Harness<S...>>();
  struct Held {
    std::vector<Index> vars;
    std::vector<Index> positions;
    std::vector<Block> rows_t;
    typename Chol::FactorRows rows;
  };
  std::vector<std::unique_ptr<Held>> held;
  // A random factor of a random error size on `vars`, added to the dense source.
  auto factor = [&](std::vector<Index> vars) -> const typename Chol::FactorRows& {
    held.push_back(std::make_unique<Held>());
    Held& f = *held.back();
    f.vars = std::move(vars);
    const int m = Sizes::sizeOfKind(std::uniform_int_distribution<int>(0, Sizes::kCount - 1)(rng));
    for (Index v : f.vars) {
      Block b = Block::Zero();
      for (int r = 0; r < h->source.width(v); ++r) {
        for (int c = 0; c < m; ++c) b(r, c) = u(rng) + (r == c ? 2.0 : 0.0);
      }
      f.rows_t.push_back(b);
      f.positions.push_back(h->position_of[static_cast<std::size_t>(v)]);
    }
    Vector rhs = Vector::Zero();
    for (int r = 0; r < m; ++r) rhs(r) = u(rng);
    h->source.addRows(f.vars, f.rows_t, rhs, m);
    f.rows = {f.positions.data(), f.rows_t.data(), static_cast<Index>(f.vars.size()), rhs};
    return f.rows;
  };
  auto older = [&](Index v) { return std::uniform_int_distribution<Index>(0, v - 1)(rng); };
  int pairs = 0;
  for (Index step = 0; step < 50; ++step) {
    const Index v = h->addVariable(rng);
    // Each added column needs a full-rank block: a prior as wide as the variable.
    h->chol.beginUpdate(1, false, h->variable_at.data());
    const int arrangement = v < 3 ? 0 : std::uniform_int_distribution<int>(0, 3)(rng);
    auto prior = [&] {
      held.push_back(std::make_unique<Held>());
      Held& f = *held.back();
      f.vars = {v};
      f.positions = {h->position_of[static_cast<std::size_t>(v)]};
      Block b = Block::Zero();
      for (int r = 0; r < h->source.width(v); ++r) {
        for (int c = 0; c < h->source.width(v); ++c) b(r, c) = u(rng) + (r == c ? 3.0 : 0.0);
      }
      f.rows_t = {b};
      Vector rhs = Vector::Zero();
      for (int r = 0; r < h->source.width(v); ++r) rhs(r) = u(rng);
      h->source.addRows(f.vars, f.rows_t, rhs, h->source.width(v));
      f.rows = {f.positions.data(), f.rows_t.data(), 1, rhs};
      return f.rows;
    };
    REQUIRE(h->chol.addFactorRows(prior()) == Status::Ok);
    if (v > 0) REQUIRE(h->chol.addFactorRows(factor({v - 1, v})) == Status::Ok);
    if (arrangement == 1) {
      REQUIRE(h->chol.addFactorRows(factor({older(v), v})) == Status::Ok);
    } else if (arrangement == 2) {
      const auto& first = factor({older(v), v});
      REQUIRE(h->chol.addFactorRows(first, factor({older(v), v})) == Status::Ok);
      ++pairs;
    } else if (arrangement == 3) {
      const Index a = older(v);
      const Index b = older(v);
      const auto& first = factor(a == b ? std::vector<Index>{a} : std::vector<Index>{a, b});
      REQUIRE(h->chol.addFactorRows(first, factor({older(v)})) == Status::Ok);
      ++pairs;
    }
    REQUIRE(h->chol.finishRowUpdate() == Status::Ok);
    h->chol.commit();
    h->source.commit();
    held.clear();
    h->checkAgainstDense();
    if (step % 5 == 2) {
      // A recomputing update in between (a relinearization's path), as the solver mixes them.
      const std::vector<Index> touched = h->grow(rng);
      h->chol.beginUpdate(1, false, h->variable_at.data());
      for (Index t : touched) h->chol.markChanged(h->position_of[static_cast<std::size_t>(t)]);
      REQUIRE(h->chol.factorize(h->source, h->variable_at.data(), h->position_of.data()) ==
              Status::Ok);
      h->chol.commit();
      h->source.commit();
      h->checkAgainstDense();
    }
    if (step % 7 == 3) h->chol.compact();
    h->checkSolve(step % 2 == 0);
  }
  CHECK(pairs > 5);
}

TEST_CASE("mixed block sizes: row updates (one factor, two together) equal dense LLT") {
  for (unsigned seed = 300; seed < 310; ++seed) runRowUpdates<3, 2>(seed);
  for (unsigned seed = 300; seed < 306; ++seed) runRowUpdates<6, 3>(seed);
}

template <int... S>
void runRejected(unsigned seed) {
  CAPTURE(seed);
  std::mt19937 rng(seed);
  auto h = std::make_unique<Harness<S...>>();
  for (Index step = 0; step < 30; ++step) {
    const std::vector<Index> touched = h->grow(rng);
    if (step > 4 && step % 3 == 0) {
      // An update made indefinite is rejected, and the factor is unchanged: it still equals the
      // dense factor of the committed matrix, after which the update goes through.
      const Index v = touched[1];
      const int w = h->source.width(v);
      const Eigen::MatrixXd saved = h->source.lambda;
      const std::vector<double> before = h->snapshot();
      h->source.lambda.block(h->source.offset(v), h->source.offset(v), w, w) -=
          1e6 * Eigen::MatrixXd::Identity(w, w);
      h->chol.beginUpdate(1, false);
      for (Index t : touched) h->chol.markChanged(h->position_of[static_cast<std::size_t>(t)]);
      CHECK(h->chol.factorize(h->source, h->variable_at.data(), h->position_of.data()) ==
            Status::NotPositiveDefinite);
      h->chol.rollback();
      h->source.lambda = saved;
      CHECK(h->snapshot() == before);
    }
    h->chol.beginUpdate(1, false);
    for (Index t : touched) h->chol.markChanged(h->position_of[static_cast<std::size_t>(t)]);
    REQUIRE(h->chol.factorize(h->source, h->variable_at.data(), h->position_of.data()) ==
            Status::Ok);
    h->chol.commit();
    h->source.commit();
    h->checkAgainstDense();
  }
}

TEST_CASE("mixed block sizes: a rejected update leaves the factor as it was") {
  for (unsigned seed = 200; seed < 208; ++seed) runRejected<3, 2>(seed);
  for (unsigned seed = 200; seed < 204; ++seed) runRejected<6, 3>(seed);
}

TEST_CASE("mixed block sizes: a full value pool is CapacityExhausted and rolls back") {
  using Chol = lslam::IncrementalCholesky<3, 2>;
  // Values for two columns and the copy of the first that the second update stages: the third
  // update's staging does not fit.
  using Small = lslam::StaticCholeskyStorageFor<lslam::BlockSizes<3, 2>, 4, 16, 28>;
  auto storage = std::make_unique<Small>();
  std::uint8_t kinds[4] = {0, 1, 0, 0};
  lslam::CholeskyArrays<3, 2> arrays = storage->arrays();
  arrays.variable_kind = kinds;
  Chol chol(arrays);
  MixedSource<3, 2> source;
  std::mt19937 rng(5);
  std::vector<Index> order;
  for (Index v = 0; v < 3; ++v) {
    source.addVariable(kinds[v]);
    order.push_back(v);
    source.addFactor(v > 0 ? v - 1 : v, v, rng);
    chol.beginUpdate(1, false);
    if (v > 0) chol.markChanged(v - 1);
    const Status s = chol.factorize(source, order.data(), order.data());
    if (v < 2) {
      REQUIRE(s == Status::Ok);
      chol.commit();
      source.commit();
    } else {
      CHECK(s == Status::CapacityExhausted);
      chol.rollback();
      CHECK(chol.columns() == 2);
      CHECK(chol.valuesEnd() == 28);
      chol.compact();
      CHECK(chol.valuesEnd() == 9 + 6 + 4);
    }
  }
}

}  // namespace
