#include "lslam/solver/id_map.h"

#include "lslam/assert.h"

namespace lslam {
namespace {
constexpr VariableId kEmpty = -1;
}

IdMap::IdMap(const IdMapArrays& arrays) : a_(arrays) {
  LSLAM_ASSERT(a_.slots >= 16 && (a_.slots & (a_.slots - 1)) == 0);
  for (std::size_t i = 0; i < a_.slots; ++i) a_.keys[i] = kEmpty;
}

std::size_t IdMap::slotOf(VariableId id) const {
  // A multiplicative hash spreads consecutive ids (the usual case) over the table.
  const std::uint64_t h = static_cast<std::uint64_t>(id) * 0x9E3779B97F4A7C15ull;
  return static_cast<std::size_t>(h >> 20) & (a_.slots - 1);
}

Index IdMap::find(VariableId id) const {
  if (id < 0) return kNoIndex;
  for (std::size_t s = slotOf(id);; s = (s + 1) & (a_.slots - 1)) {
    if (a_.keys[s] == id) return a_.values[s];
    if (a_.keys[s] == kEmpty) return kNoIndex;
  }
}

void IdMap::insert(VariableId id, Index value) {
  LSLAM_ASSERT(id >= 0);
  std::size_t s = slotOf(id);
  while (a_.keys[s] != kEmpty) {
    LSLAM_ASSERT(a_.keys[s] != id);
    s = (s + 1) & (a_.slots - 1);
  }
  a_.keys[s] = id;
  a_.values[s] = value;
}

void IdMap::eraseNewest(VariableId id) {
  for (std::size_t s = slotOf(id);; s = (s + 1) & (a_.slots - 1)) {
    LSLAM_ASSERT(a_.keys[s] != kEmpty);
    if (a_.keys[s] == id) {
      a_.keys[s] = kEmpty;
      return;
    }
  }
}

}  // namespace lslam
