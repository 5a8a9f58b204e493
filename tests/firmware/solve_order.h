#pragma once
// Test-only reference of the order in which the back-substitution (and the pool layout) visit the
// columns of an elimination tree, from its parent links alone: the roots, then depth first, each
// column before its subtree, larger siblings (and larger roots) first. Written recursively, apart
// from the library's stack-based walks.
#include <functional>
#include <vector>

#include "lslam/linear/incremental_cholesky.h"

namespace lslam::test {

// parent[k]: k's parent, or kNoIndex for a root.
inline std::vector<Index> solveOrder(const std::vector<Index>& parent) {
  const Index n = static_cast<Index>(parent.size());
  std::vector<std::vector<Index>> children(static_cast<std::size_t>(n + 1));  // n: above roots
  for (Index k = 0; k < n; ++k) {
    const Index p = parent[static_cast<std::size_t>(k)];
    children[static_cast<std::size_t>(p == kNoIndex ? n : p)].push_back(k);
  }
  std::vector<Index> order;
  std::function<void(Index)> visit = [&](Index k) {
    if (k != n) order.push_back(k);
    const auto& c = children[static_cast<std::size_t>(k)];
    for (auto it = c.rbegin(); it != c.rend(); ++it) visit(*it);
  };
  visit(n);
  return order;
}

// The same for the committed columns of a factor.
template <int D>
std::vector<Index> solveOrder(const IncrementalCholesky<D>& chol) {
  std::vector<Index> parent(static_cast<std::size_t>(chol.columns()));
  for (Index k = 0; k < chol.columns(); ++k) parent[static_cast<std::size_t>(k)] = chol.parent(k);
  return solveOrder(parent);
}

}  // namespace lslam::test
