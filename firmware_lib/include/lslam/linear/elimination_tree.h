#pragma once
// The postorder of an elimination order (the step CHOLMOD's analysis takes after AMD or COLAMD).
//
// Any order in which every column comes before its parent in the elimination tree eliminates the
// same way: the same fill, and the same factor up to the renumbering (a column's rows are its
// ancestors, which keep their relative order). A postorder is such an order in which every subtree
// occupies consecutive positions, its root last. The back-substitution and the pool layout walk
// the tree depth-first from the root, the child with the highest position first, so in a
// postorder they visit positions n - 1, n - 2, ... in turn, and every per-column array (d, the
// counts, the tree links, the solution) is read in sequence instead of at random.
//
// COLAMD's order is not one (it orders the columns of A, and the newest variable is pinned last
// afterwards): in it, most of the solve's steps from one column to the next jump, often to another
// cache line of every per-column array.
#include "lslam/linear/index.h"
#include "lslam/linear/information_source.h"

namespace lslam {

// order[k] is the variable at position k for k < n, and position[v] its inverse; variables at
// position n or beyond are left out (their columns come after). Rewrites order[0..n) into the
// postorder of the elimination tree of `graph`'s pattern in that order which keeps siblings, and
// the trees of a forest, in their relative order; position n - 1, always a root, therefore keeps
// its variable. `position` is not updated. parent_scratch and count_scratch: n entries each, whose
// contents are lost.
void postorderEliminationOrder(Index n, Index* order, const Index* position,
                               const NeighbourGraph& graph, Index* parent_scratch,
                               Index* count_scratch);

}  // namespace lslam
