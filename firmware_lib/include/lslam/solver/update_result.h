#pragma once
#include <cstdint>

#include "lslam/linear/index.h"
#include "lslam/status.h"

namespace lslam {

// What one call did (as GTSAM's ISAM2Result): for diagnostics, logs and the per-step CSV.
struct UpdateResult {
  Status status = Status::Ok;
  Index variables_added = 0;
  Index factors_added = 0;
  Index variables_relinearized = 0;
  Index columns_refactored = 0;     // columns of L recomputed (etree paths, or all on a reorder)
  Index variables_solved = 0;       // variables back-substituted
  std::int64_t block_products = 0;  // 3x3 multiply-adds of the factorization
  bool reordered = false;           // a COLAMD reordering (and full refactorization) happened
  bool refactored_fully = false;    // every column recomputed (a reordering, or most relinearized)
  bool ordering_prepared = false;   // a COLAMD ordering was computed for the next update to apply
  bool top_reordered = false;       // the affected top alone was reordered and refactorized
  bool compacted = false;           // the block pool was compacted
  bool reordered_for_room = false;  // the update did not fit in its order and ran in a fresh one
  bool laid_out = false;            // the last full refactorization's layout was done here
  bool relinearization_deferred = false;    // due candidates wait for the next reordering
  std::int64_t relinearization_charge = 0;  // block products the wait charged to the ordering's
                                            // work budget (its first update only)
  bool spread_started = false;              // a reordering spread over the next updates began
  bool spread_abandoned = false;            // ...was given up (the live factor serves on)
  bool spread_swapped = false;              // ...or replaced the live factor here
  std::int64_t spread_products = 0;         // block products the spread reordering spent here
  Index factor_blocks = 0;                  // nonzero blocks of L after the call
  Index iterations = 0;  // optimize(): Gauss-Newton iterations; solve(): urgent iterations
};

}  // namespace lslam
