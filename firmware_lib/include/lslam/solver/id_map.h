#pragma once
// Fixed-capacity map from the user's variable ids (any non-negative 64-bit value) to dense
// indices: open addressing with linear probing in a power-of-two table, at most half full, so a
// lookup touches a couple of slots. Keys are only ever erased newest first (rolling back an
// update), which restores the table bit for bit and needs no tombstones.
#include <cstddef>
#include <cstdint>

#include "lslam/linear/index.h"

namespace lslam {

using VariableId = std::int64_t;

struct IdMapArrays {
  std::size_t slots = 0;  // a power of two, >= 2 * capacity
  VariableId* keys = nullptr;
  Index* values = nullptr;
};

class IdMap {
 public:
  explicit IdMap(const IdMapArrays& arrays);

  Index find(VariableId id) const;  // kNoIndex if absent
  // Precondition: id >= 0, absent, and the map below capacity.
  void insert(VariableId id, Index value);
  // Precondition: id was the most recently inserted key still present.
  void eraseNewest(VariableId id);

 private:
  std::size_t slotOf(VariableId id) const;
  IdMapArrays a_;
};

constexpr std::size_t idMapSlots(std::size_t capacity) {
  std::size_t s = 16;
  while (s < 2 * capacity) s *= 2;
  return s;
}

template <std::size_t Capacity>
class StaticIdMapStorage {
 public:
  IdMapArrays arrays() { return IdMapArrays{idMapSlots(Capacity), keys_, values_}; }

 private:
  VariableId keys_[idMapSlots(Capacity)];
  Index values_[idMapSlots(Capacity)];
};

}  // namespace lslam
