#include "lslam/linear/colamd_ordering.h"

#include <colamd.h>

#include "lslam/assert.h"

namespace lslam {

ColamdOrdering::ColamdOrdering(const ColamdArrays& arrays) : a_(arrays) {
  // The static workspace must cover what COLAMD asks for at full capacity.
  LSLAM_ASSERT(colamd_recommended(static_cast<int>(a_.max_nonzeros), static_cast<int>(a_.max_rows),
                                  static_cast<int>(a_.max_columns)) <=
               colamdWorkspaceSize(a_.max_nonzeros, a_.max_rows, a_.max_columns));
}

void ColamdOrdering::begin() {
  columns_ = 0;
  nonzeros_ = 0;
  a_.p[0] = 0;
}

void ColamdOrdering::startColumn() {
  LSLAM_ASSERT(columns_ < a_.max_columns);
  ++columns_;
  a_.p[columns_] = static_cast<int>(nonzeros_);
}

bool ColamdOrdering::addEntry(Index row) {
  if (nonzeros_ >= a_.max_nonzeros) return false;
  a_.a[nonzeros_++] = static_cast<int>(row);
  a_.p[columns_] = static_cast<int>(nonzeros_);
  return true;
}

Status ColamdOrdering::order(Index rows, Index* order) {
  if (static_cast<std::size_t>(rows) > a_.max_rows) return Status::WorkspaceExhausted;
  const int n_col = static_cast<int>(columns_);
  const std::size_t alen = colamdWorkspaceSize(a_.max_nonzeros, a_.max_rows, a_.max_columns);
  if (colamd_recommended(static_cast<int>(nonzeros_), rows, n_col) > alen) {
    return Status::WorkspaceExhausted;
  }
  double knobs[COLAMD_KNOBS];
  int stats[COLAMD_STATS];
  colamd_set_defaults(knobs);
  if (colamd(rows, n_col, static_cast<int>(alen), a_.a, a_.p, knobs, stats) == 0) {
    return Status::InvalidArgument;
  }
  for (int i = 0; i < n_col; ++i) order[i] = a_.p[i];
  return Status::Ok;
}

}  // namespace lslam
