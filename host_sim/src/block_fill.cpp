// The block fill of a dataset's batch Cholesky factor (model_run.h, batchFactorFill).
#include <algorithm>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "batch_common.h"
#include "host_sim/model_run.h"

namespace lslam::sim {

BatchFill batchFactorFill(const ModelDataset& d) {
  // Variables in order of first appearance in a factor; one COLAMD row per factor.
  std::unordered_map<VariableKey, int, VariableKeyHash> index;
  std::vector<std::vector<int>> col_rows;
  std::vector<std::pair<int, int>> edges;  // binary factors' distinct variables
  const auto indexOf = [&](const VariableKey& key) {
    const auto [it, inserted] = index.emplace(key, static_cast<int>(col_rows.size()));
    if (inserted) col_rows.emplace_back();
    return it->second;
  };
  int n_row = 0;
  for (const ModelFactor& f : d.factors) {
    const int a = indexOf(f.first);
    const int b = arity(f.kind) == 2 ? indexOf(f.second) : a;
    col_rows[static_cast<std::size_t>(a)].push_back(n_row);
    if (b != a) {
      col_rows[static_cast<std::size_t>(b)].push_back(n_row);
      edges.emplace_back(a, b);
    }
    ++n_row;
  }
  const std::size_t n = col_rows.size();
  if (n == 0) return BatchFill{};
  const std::vector<int> perm = batch_detail::colamdOrdering(n_row, col_rows, "batchFactorBlocks");
  std::vector<int> position(n);
  for (std::size_t p = 0; p < n; ++p)
    position[static_cast<std::size_t>(perm[p])] = static_cast<int>(p);

  // Each position's neighbours at lower positions (the nonzeros of its row of H below the
  // diagonal).
  std::vector<std::vector<int>> lower(n);
  for (const auto& [a, b] : edges) {
    const int pa = position[static_cast<std::size_t>(a)],
              pb = position[static_cast<std::size_t>(b)];
    lower[static_cast<std::size_t>(std::max(pa, pb))].push_back(std::min(pa, pb));
  }

  // The elimination tree (with path compression through `ancestor`), then the row counts of L:
  // row i holds column k < i exactly when k lies on the tree path from one of i's lower
  // neighbours up to i, each column counted once per row (`mark`).
  std::vector<int> parent(n, -1), ancestor(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    for (int r : lower[i]) {
      while (ancestor[static_cast<std::size_t>(r)] != -1 &&
             ancestor[static_cast<std::size_t>(r)] != static_cast<int>(i)) {
        const int next = ancestor[static_cast<std::size_t>(r)];
        ancestor[static_cast<std::size_t>(r)] = static_cast<int>(i);
        r = next;
      }
      if (ancestor[static_cast<std::size_t>(r)] == -1) {
        ancestor[static_cast<std::size_t>(r)] = static_cast<int>(i);
        parent[static_cast<std::size_t>(r)] = static_cast<int>(i);
      }
    }
  }
  std::int64_t blocks = static_cast<std::int64_t>(n);  // the diagonal
  std::vector<std::int64_t> column_count(n, 1);
  std::vector<std::size_t> mark(n, n);
  for (std::size_t i = 0; i < n; ++i) {
    mark[i] = i;
    for (int k : lower[i]) {
      while (k != -1 && mark[static_cast<std::size_t>(k)] != i) {
        mark[static_cast<std::size_t>(k)] = i;
        ++blocks;
        ++column_count[static_cast<std::size_t>(k)];
        k = parent[static_cast<std::size_t>(k)];
      }
    }
  }
  // A column of s blocks sends s (s - 1) / 2 block products to the later ones.
  std::int64_t products = 0;
  for (const std::int64_t count : column_count) products += count * (count - 1) / 2;
  return BatchFill{blocks, products};
}

std::int64_t batchFactorBlocks(const ModelDataset& d) {
  return batchFactorFill(d).blocks;
}

}  // namespace lslam::sim
