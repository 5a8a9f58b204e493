#pragma once
// What the solver derives from a model (slam_2d.h, slam_3d.h): the block sizes of its variable
// kinds, in list order, for the factorization (block_sizes.h), and the kind index of a type.
#include "lslam/linear/block_sizes.h"
#include "lslam/type_list.h"

namespace lslam {

template <class VariableList>
struct BlockSizesOfList;
template <class... V>
struct BlockSizesOfList<TypeList<V...>> {
  using type = BlockSizes<V::kDof...>;
};

// BlockSizes<kDof of each variable kind...>, e.g. BlockSizes<3, 2> for Slam2D.
template <class Model>
using ModelBlockSizes = typename BlockSizesOfList<typename Model::Variables>::type;

template <class Model, class Variable>
inline constexpr int kVariableKind = IndexOf<Variable, typename Model::Variables>::value;
template <class Model, class Factor>
inline constexpr int kFactorKind = IndexOf<Factor, typename Model::Factors>::value;

}  // namespace lslam
