#pragma once
// Fill-reducing column ordering with SuiteSparse COLAMD, in a workspace sized at compile time.
// The caller describes the pattern of a matrix A (rows = factors, columns = variables) column by
// column; COLAMD orders the columns so that the Cholesky factor of A^T A (the pattern of Lambda)
// has little fill. colamd() itself never allocates: the workspace is ours.
#include <cstddef>

#include "lslam/linear/index.h"
#include "lslam/status.h"

namespace lslam {

// An upper bound of colamd_recommended(nnz, n_row, n_col) (2 nnz + the column and row
// structures + elbow room), usable at compile time; checked against the library at construction.
constexpr std::size_t colamdWorkspaceSize(std::size_t nnz, std::size_t n_row, std::size_t n_col) {
  return 2 * nnz + nnz / 5 + 8 * (n_col + 1) + 6 * (n_row + 1) + n_col + 64;
}

struct ColamdArrays {
  std::size_t max_nonzeros = 0;
  std::size_t max_rows = 0;
  std::size_t max_columns = 0;
  int* a = nullptr;  // colamdWorkspaceSize(max_nonzeros, max_rows, max_columns)
  int* p = nullptr;  // max_columns + 1
};

class ColamdOrdering {
 public:
  explicit ColamdOrdering(const ColamdArrays& arrays);

  void begin();
  void startColumn();
  // Row `row` of A has a nonzero in the current column. Returns false when the workspace is full.
  [[nodiscard]] bool addEntry(Index row);
  // Orders the columns described so far; order[i] is the column placed i-th.
  [[nodiscard]] Status order(Index rows, Index* order);

 private:
  ColamdArrays a_;
  std::size_t columns_ = 0;
  std::size_t nonzeros_ = 0;
};

template <std::size_t MaxNonzeros, std::size_t MaxRows, std::size_t MaxColumns>
class StaticColamdStorage {
 public:
  ColamdArrays arrays() {
    ColamdArrays c;
    c.max_nonzeros = MaxNonzeros;
    c.max_rows = MaxRows;
    c.max_columns = MaxColumns;
    c.a = a_;
    c.p = p_;
    return c;
  }

 private:
  int a_[colamdWorkspaceSize(MaxNonzeros, MaxRows, MaxColumns)];
  int p_[MaxColumns + 1];
};

}  // namespace lslam
