// The postorder of an elimination order against a reference built independently: the elimination
// tree from a dense symbolic factorization of the permuted pattern, then a recursive depth-first
// walk. Also checked without the reference: the fill is unchanged, every subtree is a run of
// consecutive positions ending at its root, and the solve's depth-first walk visits the positions
// in descending order.
#include <doctest/doctest.h>

#include <algorithm>
#include <functional>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "lslam/linear/elimination_tree.h"
#include "solve_order.h"

namespace {

using lslam::Index;

class AdjacencyGraph final : public lslam::NeighbourGraph {
 public:
  explicit AdjacencyGraph(Index variables) : neighbours_(static_cast<std::size_t>(variables)) {}
  void connect(Index a, Index b) {
    neighbours_[a].insert(b);
    neighbours_[b].insert(a);
  }
  bool adjacent(Index a, Index b) const { return neighbours_[a].count(b) != 0; }
  void visitNeighbours(Index v, lslam::NeighbourVisitor& visitor) const override {
    for (Index u : neighbours_[v]) visitor.visit(u);
  }

 private:
  std::vector<std::set<Index>> neighbours_;
};

// The filled pattern of L for the first n positions of `order`, by dense symbolic elimination.
std::vector<std::vector<bool>> filledPattern(const AdjacencyGraph& g,
                                             const std::vector<Index>& order, Index n) {
  std::vector<std::vector<bool>> p(n, std::vector<bool>(n, false));
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < n; ++j) p[i][j] = i != j && g.adjacent(order[i], order[j]);
  for (Index k = 0; k < n; ++k)
    for (Index i = k + 1; i < n; ++i)
      for (Index j = k + 1; j < n; ++j)
        if (p[i][k] && p[j][k] && i != j) p[i][j] = true;
  return p;
}

std::size_t fill(const std::vector<std::vector<bool>>& p) {
  std::size_t count = 0;
  for (std::size_t k = 0; k < p.size(); ++k)
    for (std::size_t i = k + 1; i < p.size(); ++i) count += p[i][k] ? 1 : 0;
  return count;
}

std::vector<Index> parents(const std::vector<std::vector<bool>>& p) {
  const Index n = static_cast<Index>(p.size());
  std::vector<Index> parent(n, lslam::kNoIndex);
  for (Index k = 0; k < n; ++k)
    for (Index i = k + 1; i < n && parent[k] == lslam::kNoIndex; ++i)
      if (p[i][k]) parent[k] = i;
  return parent;
}

// Recursive postorder: roots ascending, children ascending, each subtree before its root.
std::vector<Index> referencePostorder(const std::vector<Index>& parent) {
  const Index n = static_cast<Index>(parent.size());
  std::vector<std::vector<Index>> children(n);
  for (Index k = 0; k < n; ++k)
    if (parent[k] != lslam::kNoIndex) children[parent[k]].push_back(k);
  std::vector<Index> out;
  std::function<void(Index)> walk = [&](Index k) {
    for (Index c : children[k]) walk(c);
    out.push_back(k);
  };
  for (Index k = 0; k < n; ++k)
    if (parent[k] == lslam::kNoIndex) walk(k);
  return out;
}

struct Case {
  AdjacencyGraph graph;
  std::vector<Index> order;  // every variable; the first n are postordered
  Index n;
};

// A random graph: a chain through the variables (some links dropped, making a forest) plus random
// extra edges, in a random order whose last `left_out` positions the postorder must ignore.
Case randomCase(std::mt19937& rng) {
  const Index variables = std::uniform_int_distribution<Index>(1, 40)(rng);
  Case c{AdjacencyGraph(variables), std::vector<Index>(variables), 0};
  std::bernoulli_distribution keep_link(0.9);
  for (Index v = 1; v < variables; ++v)
    if (keep_link(rng)) c.graph.connect(v - 1, v);
  const Index extra = std::uniform_int_distribution<Index>(0, variables)(rng);
  std::uniform_int_distribution<Index> any(0, variables - 1);
  for (Index e = 0; e < extra; ++e) {
    const Index a = any(rng);
    const Index b = any(rng);
    if (a != b) c.graph.connect(a, b);
  }
  std::iota(c.order.begin(), c.order.end(), 0);
  std::shuffle(c.order.begin(), c.order.end(), rng);
  c.n = variables - std::uniform_int_distribution<Index>(0, std::min<Index>(3, variables - 1))(rng);
  return c;
}

}  // namespace

TEST_CASE(
    "postorder of an elimination order: the reference postorder, same fill, subtrees in runs") {
  std::mt19937 rng(4242);
  for (int trial = 0; trial < 400; ++trial) {
    CAPTURE(trial);
    Case c = randomCase(rng);
    const Index variables = static_cast<Index>(c.order.size());
    std::vector<Index> position(variables);
    for (Index k = 0; k < variables; ++k) position[c.order[k]] = k;
    const auto before = filledPattern(c.graph, c.order, c.n);
    std::vector<Index> expected(c.order);
    const std::vector<Index> reference = referencePostorder(parents(before));
    for (Index k = 0; k < c.n; ++k) expected[k] = c.order[reference[k]];

    // Scratch filled with garbage: the function may not rely on its contents.
    std::vector<Index> parent_scratch(c.n, 12345), count_scratch(c.n, -777);
    std::vector<Index> result(c.order);
    lslam::postorderEliminationOrder(c.n, result.data(), position.data(), c.graph,
                                     parent_scratch.data(), count_scratch.data());
    CHECK(result == expected);
    CHECK(result.back() == c.order.back());
    if (c.n > 0) CHECK(result[c.n - 1] == c.order[c.n - 1]);

    const auto after = filledPattern(c.graph, result, c.n);
    CHECK(fill(after) == fill(before));
    const std::vector<Index> parent = parents(after);
    std::vector<Index> size(c.n, 1);
    for (Index k = 0; k < c.n; ++k)
      if (parent[k] != lslam::kNoIndex) size[parent[k]] += size[k];
    // The solve's walk visits n - 1, n - 2, ..., 0 in turn.
    std::vector<Index> descending(c.n);
    std::iota(descending.rbegin(), descending.rend(), 0);
    CHECK(lslam::test::solveOrder(parent) == descending);
    for (Index k = 0; k < c.n; ++k) {
      // The size[k] - 1 positions below k are all k's descendants.
      for (Index d = k - size[k] + 1; d < k; ++d) {
        Index a = d;
        while (a != lslam::kNoIndex && a != k) a = parent[a];
        CHECK(a == k);
      }
    }
  }
}
