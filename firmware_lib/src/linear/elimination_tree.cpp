#include "lslam/linear/elimination_tree.h"

namespace lslam {

namespace {

// Liu's algorithm: columns in position order; for each neighbour at an earlier position, climb
// from it to the root of the tree built so far and hang that root below the current column. The
// ancestor links are compressed on the way (each node climbed now points at the current column),
// so the whole tree takes about one pass over the pattern.
class EliminationTreeBuilder final : public NeighbourVisitor {
 public:
  EliminationTreeBuilder(const Index* position, Index* parent, Index* ancestor)
      : position_(position), parent_(parent), ancestor_(ancestor) {}

  void startColumn(Index k) {
    k_ = k;
    parent_[k] = kNoIndex;
    ancestor_[k] = kNoIndex;
  }

  void visit(Index variable) override {
    Index i = position_[variable];
    if (i >= k_) return;  // a later column (or one left out): its turn comes, or never
    while (ancestor_[i] != kNoIndex && ancestor_[i] != k_) {
      const Index next = ancestor_[i];
      ancestor_[i] = k_;
      i = next;
    }
    if (ancestor_[i] == kNoIndex) {
      ancestor_[i] = k_;
      parent_[i] = k_;
    }
  }

 private:
  const Index* position_;
  Index* parent_;
  Index* ancestor_;
  Index k_ = 0;
};

}  // namespace

void postorderEliminationOrder(Index n, Index* order, const Index* position,
                               const NeighbourGraph& graph, Index* parent_scratch,
                               Index* count_scratch) {
  Index* const parent = parent_scratch;
  EliminationTreeBuilder builder(position, parent, count_scratch);
  for (Index k = 0; k < n; ++k) {
    builder.startColumn(k);
    graph.visitNeighbours(order[k], builder);
  }
  // Subtree sizes: a parent's position is above its children's, so one ascending pass adds every
  // child's finished size into its parent before the parent's own turn.
  Index* const size = count_scratch;
  for (Index k = 0; k < n; ++k) size[k] = 1;
  for (Index k = 0; k < n; ++k) {
    if (parent[k] != kNoIndex) size[parent[k]] += size[k];
  }
  // Postorder positions, parents before children (descending): a subtree takes the highest free
  // positions below its parent's, its root the top one; the trees of the forest likewise below n.
  // Once node k is numbered its parent link and size are spent, so the same two arrays then hold
  // the next free position below k (for its children) and k's postorder position.
  Index* const next_free = parent_scratch;
  Index* const postorder = count_scratch;
  Index next_root_free = n - 1;
  for (Index k = n - 1; k >= 0; --k) {
    Index& next_free_for_k = parent[k] == kNoIndex ? next_root_free : next_free[parent[k]];
    const Index mine = next_free_for_k;
    next_free_for_k -= size[k];  // k's subtree takes [mine - size[k] + 1, mine]
    postorder[k] = mine;
    next_free[k] = mine - 1;
  }
  // Apply: the old order goes to the spent parent array first.
  Index* const old_order = parent_scratch;
  for (Index k = 0; k < n; ++k) old_order[k] = order[k];
  for (Index k = 0; k < n; ++k) order[postorder[k]] = old_order[k];
}

}  // namespace lslam
