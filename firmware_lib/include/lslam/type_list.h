#pragma once
// Compile-time lists of types: a model names its variable kinds and factor kinds with them, and the
// solver turns a kind's run-time index into a call of that kind's code with a switch generated from
// the list (visitKind), so no virtual call and no RTTI reach the hot loops.
#include <cstddef>
#include <type_traits>
#include <utility>

namespace lslam {

template <class... T>
struct TypeList {
  static constexpr int kSize = static_cast<int>(sizeof...(T));
};

// The position of T in List (a compile error if it is absent).
template <class T, class List>
struct IndexOf;
template <class T, class... Rest>
struct IndexOf<T, TypeList<T, Rest...>> : std::integral_constant<int, 0> {};
template <class T, class Head, class... Rest>
struct IndexOf<T, TypeList<Head, Rest...>>
    : std::integral_constant<int, 1 + IndexOf<T, TypeList<Rest...>>::value> {};

// The I-th type of List.
template <int I, class List>
struct TypeAt;
template <class Head, class... Rest>
struct TypeAt<0, TypeList<Head, Rest...>> {
  using type = Head;
};
template <int I, class Head, class... Rest>
struct TypeAt<I, TypeList<Head, Rest...>> {
  using type = typename TypeAt<I - 1, TypeList<Rest...>>::type;
};
template <int I, class List>
using TypeAtT = typename TypeAt<I, List>::type;

namespace detail {
template <class... T, class F, std::size_t... I>
bool visitKindImpl(TypeList<T...>, int kind, F&& f, std::index_sequence<I...>) {
  return ((kind == static_cast<int>(I) ? (f(static_cast<T*>(nullptr)), true) : false) || ...);
}
}  // namespace detail

// f(static_cast<K*>(nullptr)) for K the kind-th type of List; false (and no call) for a kind out
// of range. The pointer carries the type only: write `[&](auto* tag) { using K =
// std::remove_pointer_t<decltype(tag)>; ... }`.
template <class List, class F>
bool visitKind(int kind, F&& f) {
  return detail::visitKindImpl(List{}, kind, std::forward<F>(f),
                               std::make_index_sequence<static_cast<std::size_t>(List::kSize)>{});
}

}  // namespace lslam
