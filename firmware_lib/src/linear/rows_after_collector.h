#pragma once
// Internal to the factorization sources: collects a variable's neighbours that come after a column.
#include <cstdint>

#include "lslam/linear/index.h"
#include "lslam/linear/information_source.h"

namespace lslam {
namespace detail {

// Adds the positions of a variable's neighbours that come after column k to a row list, once each.
class RowsAfterCollector final : public NeighbourVisitor {
 public:
  RowsAfterCollector(const Index* position_of, Index k, std::uint32_t* mark, std::uint32_t id,
                     Index* out)
      : position_of_(position_of), k_(k), mark_(mark), id_(id), out_(out) {}
  void visit(Index variable) override {
    const Index r = position_of_[variable];
    if (r > k_ && mark_[r] != id_) {
      mark_[r] = id_;
      out_[count_++] = r;
    }
  }
  Index count() const { return count_; }

 private:
  const Index* position_of_;
  Index k_;
  std::uint32_t* mark_;
  std::uint32_t id_;
  Index* out_;
  Index count_ = 0;
};

}  // namespace detail
}  // namespace lslam
