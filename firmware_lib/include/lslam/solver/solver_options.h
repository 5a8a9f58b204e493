#pragma once
#include <cstdint>

#include "lslam/linear/index.h"

namespace lslam {

struct SolverOptions {
  // A variable becomes a relinearization candidate (its factors' Jacobians to be recomputed at
  // the current estimate) when its solution delta moved more than this far from its linearization
  // point (max-norm over x, y in meters and theta in radians).
  double relinearize_threshold = 0.01;
  // The threshold per variable kind of a model (pose, landmark; a 2D pose graph has only the
  // pose): 0 takes relinearize_threshold. A landmark's delta is in its own units (meters), which
  // may call for another bar than a pose's mix of meters and radians.
  double relinearize_threshold_of_kind[2] = {0.0, 0.0};
  // When candidates are relinearized: all together, at the next update after one of them passes
  // relinearize_urgent_threshold (a large step taken at a stale linearization point is where the
  // estimate loses accuracy), at every reordering (where the full refactorization makes it free),
  // and, if relinearize_skip > 0, at least every relinearize_skip updates (iSAM2's
  // relinearizeSkip). Waiting lets the candidates of many steps share one recomputation of their
  // etree paths, and keeps the updates in between pure additions, which take the cheap row
  // update (firmware_lib/README.md, Relinearization). The urgent threshold trades fewer, larger
  // relinearizations against more linearization error while candidates wait.
  double relinearize_urgent_threshold = 0.1;
  Index relinearize_skip = 0;
  // An update that relinearizes without reordering (an urgent candidate, or relinearize_skip)
  // takes only the candidates past this (at most relinearize_urgent_threshold); the others wait,
  // still candidates, for the next reordering (free there) or the next such update. If the update
  // refactorizes every column anyway (most variables relinearized), it takes every candidate.
  // Fewer variables relinearized at once keep more of these updates in place, below
  // reorder_relinearized_share: it trades fewer full refactorizations against candidates waiting
  // longer at stale linearization points. 0: every candidate.
  double relinearize_partial_threshold = 0.05;
  // When a back-substitution leaves a candidate past relinearize_urgent_threshold,
  // the same call relinearizes the candidates and solves again, up to this many times, instead of
  // at the next update. It trades a dearer step where the estimate moved far against an estimate
  // that does not wait one update at a stale linearization point (the last update's, for good).
  // 0: the candidates wait for the next update.
  Index urgent_iterations = 0;
  // Below this many variables every candidate is urgent, and a solve that leaves
  // one relinearizes and solves again, up to converge_iterations times: Gauss-Newton to the
  // relinearization threshold within each update. A graph this small costs little to relinearize
  // whole, and it is where one linear step from a stale point falls furthest short (tinyGrid3D:
  // 124 % above the optimum after its last update without it). It trades a dearer update while
  // the map is small against its estimate; past the bar, the rules above. 0: off.
  Index converge_below_variables = 128;
  Index converge_iterations = 16;
  // Partial back-substitution: a subtree of the elimination tree is not re-solved when nothing it
  // depends on moved by more than this (max-norm). 0 gives the exact solution of L^T x = d.
  // 1e-4 (0.1 mm, 1e-4 rad) is a hundredth of relinearize_threshold, the linearization error the
  // estimate tolerates anyway (iSAM2's wildfire threshold is 1e-3). It trades fewer variables
  // re-solved per loop closure against a solution that may lag the exact one by that much.
  double backsubstitution_tolerance = 1e-4;
  bool partial_backsubstitution = true;
  // Back-substitute at the end of every update (otherwise call solve()).
  bool solve_after_update = true;
  // Ordering policy (firmware_lib/README.md, Ordering): the whole graph is reordered with COLAMD
  // (the newest variable last) when the factor has grown by this factor since the last ordering...
  double reorder_growth = 1.5;
  // ...or when the updates since the last ordering have spent more work on the factor's growth
  // (each update's block products times the growth since the ordering) than this many times the
  // block products of the ordering's factorization: a rent-or-buy rule, so that a graph whose loop
  // closures run through a large top reorders sooner than one whose loop closures are cheap next
  // to a refactorization. 0: off.
  double reorder_excess_ratio = 2.0;
  // ...or when one update recomputed more than this many columns (a long etree path; 0: off).
  // Off by default: on the public datasets it never fires before another rule, and on a
  // revisit-heavy map a long path is the dense top itself, which no ordering shortens (a 5,000-pose
  // grid reordered every 4 updates, 88 s of a 99 s run).
  Index reorder_path_columns = 0;
  // ...or at once, with this update's factors in the ordering, when an update adds more loop
  // closures (factors reaching back before the newest pose) than this: a burst (a map merge, or a
  // file that lists its loop closures after every pose) fills the current order in far beyond a
  // fresh order that holds its factors. 32 lies well above an online step's few loop closures
  // (at most 6 in the datasets), so that only bursts take this path. 0: off.
  Index reorder_burst_loop_closures = 32;
  // ...or when an update relinearizes more than this share of the variables, which refactorizes
  // every column; that reorders too only once the factor has grown by this factor since the last
  // ordering (until then a fresh COLAMD order would be about the same). reorder_refresh_growth
  // trades fewer orderings against more fill between them.
  double reorder_relinearized_share = 0.05;
  double reorder_refresh_growth = 1.1;
  // ...and so does one whose recomputation in place would take more block products than this many
  // times a full refactorization (estimated from the last one, scaled by the factor's growth). In
  // place, a column costs twice (its old contribution is taken back), and a few hundred variables
  // relinearized under a stale ordering can reach most of the top, which then costs more than
  // refactorizing every column. 0: off.
  double relinearize_full_cost_ratio = 1.0;
  // A due relinearization that would take more block products than this (of the model's largest
  // block size), in place and by a full refactorization alike, waits for the next reordering,
  // which relinearizes it at no extra cost; its in-place estimate is charged to that reordering's
  // work budget (reorder_excess_ratio) the first time it waits, so that the reordering comes sooner
  // the dearer it would have been (with reorder_excess_ratio 0 it waits for the growth rule or the
  // cap below). Only a dense top costs this much: a revisit-heavy map, where loop closures spend
  // the budget and reorder every few dozen updates anyway (a 5,000-pose grid relinearized at up to
  // 150 M products per update, 80 % of its run; the public datasets stay under 1.4 M). The bar
  // trades candidates waiting at a stale point on such a map against steps that cost a
  // refactorization. 0: off.
  std::int64_t relinearize_defer_products = 4000000;
  // The longest wait, in updates; then the relinearization runs (the grid's reorderings come
  // within about 50 updates; 64 cost it 2x the time). It bounds how long a map that stops closing
  // loops keeps candidates at a stale point.
  Index relinearize_defer_updates = 256;
  // Updates that only add factors (no variable relinearized, no reordering) rotate the added
  // factors' whitened rows into L along their etree paths (IncrementalCholesky::addFactorRows):
  // O(s) work per column of structure s instead of O(s^2) for recomputing the column. Off: every
  // update recomputes its columns (factorize()).
  bool row_updates = true;
  // Reordered updates (iSAM2's re-elimination of the top of the tree): when the affected part of
  // an update holds at least this many existing columns, it is reordered with COLAMD, the
  // variables of the added factors last, and refactorized from its Schur complement (no column
  // outside it changes). Smaller updates (odometry) take the plain update in the current order.
  // Off by default: the top it builds is a dense clique of 3x3 blocks, which makes it slower than
  // the plain update (firmware_lib/README.md, Ordering).
  bool reorder_affected_top = false;
  Index reorder_top_min_columns = 8;
  // A reordering is split over two updates: the update at which the policy above first asks for
  // one runs as usual and then computes the COLAMD ordering (of every variable it leaves
  // committed); the next update applies it, with the variables added since appended last, and
  // refactorizes. The fresh ordering is then one update old, which costs little fill, and the
  // dearest update of a long run (the refactorization of the whole factor) does not also pay for
  // COLAMD. Off: both in one update.
  bool prepare_ordering_ahead = true;
  // ...once the last full refactorization took at least this many block products: the split
  // trades one more update in the stale order (more total work) for a cheaper worst step. Which
  // reordering is too dear for one update depends on the platform's step budget (a block product
  // is ~5 ns on the host, ~100 instructions on the Cortex-M7), so the default splits them all.
  std::int64_t prepare_ordering_min_products = 0;
  // A reordering whose full refactorization would take more block products than this (the last
  // one's count) is spread over several updates when the smoother has the memory of a second
  // factor (SpreadReordering): the live factor keeps serving while the reordered one is built in
  // steps of this many products, then takes the factors added meanwhile by row updates and
  // replaces it. It trades one more factor's memory and the replayed row updates for a worst step
  // of about this size. 0: never.
  std::int64_t spread_reorder_products = 0;
  // Never reorder graphs smaller than this (chronological order is optimal for a chain).
  Index reorder_min_variables = 50;
  // Information of the prior that anchors the very first pose when the caller gives none; it
  // leaves the problem with the caller's first prior (see "The gauge" in smoother.h).
  double anchor_information = 1e6;
};

}  // namespace lslam
