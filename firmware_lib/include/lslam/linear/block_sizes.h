#pragma once
// The block sizes a factorization works with: the tangent sizes of a model's variable kinds, for
// example <3> (2D poses), <3, 2> (2D poses and point landmarks) or <6, 3> (3D poses and points).
// Each column of the factor has its variable's size and block (r, c) is size(r) x size(c): no
// block is padded to the largest size. Kernels stay fixed-size: withSize() turns a size known at
// run time into a compile-time constant by a switch over the model's few sizes.
#include <type_traits>

namespace lslam {

template <int... S>
struct BlockSizes {
  static_assert(sizeof...(S) >= 1, "at least one block size");
  static_assert(((S >= 1 && S <= 6) && ...), "block sizes 1..6");
  static constexpr int kCount = static_cast<int>(sizeof...(S));
  static constexpr bool kUniform = kCount == 1;
  static constexpr int kMax = [] {
    int m = 0;
    ((m = S > m ? S : m), ...);
    return m;
  }();
  // The size of kind `kind` (the position of the size in the list).
  static constexpr int sizeOfKind(int kind) {
    constexpr int sizes[] = {S...};
    return sizes[kind];
  }
};

template <int N>
using SizeConstant = std::integral_constant<int, N>;

// f(SizeConstant<size>{}) for a size of the list (one of S...). With one size, no branch at all.
template <int... S, class F>
inline void withSize(int size, F&& f) {
  if constexpr (sizeof...(S) == 1) {
    static_cast<void>(size);
    (f(SizeConstant<S>{}), ...);
  } else {
    static_cast<void>(((size == S ? (f(SizeConstant<S>{}), true) : false) || ...));
  }
}

}  // namespace lslam
