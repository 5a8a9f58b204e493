#pragma once
// How the solver's units see the graph they work on, FactorGraph<Model> (the model's kinds). The
// units are templates over the graph and the factor, compiled once per model in their sources;
// the adapter is the one place that names what they read of the graph.
#include <type_traits>

#include "lslam/graph/factor_graph.h"
#include "lslam/linear/incremental_cholesky.h"
#include "lslam/linear/index.h"

namespace lslam {

// Per graph type: the number of variable kinds, a variable's kind and degrees of freedom, a
// factor's error rows, and the relinearization of a variable at its linearization point moved by
// its solution delta.
template <class Graph>
struct GraphAdapter;

template <class Model>
struct GraphAdapter<FactorGraph<Model>> {
  static constexpr int kKinds = Model::Variables::kSize;
  static int kindOf(const FactorGraph<Model>& graph, Index v) { return graph.variableKind(v); }
  static int dofOfKind(int kind) { return ModelBlockSizes<Model>::sizeOfKind(kind); }
  static int errorRows(const FactorGraph<Model>& graph, Index f) {
    int rows = 0;
    visitKind<typename Model::Factors>(graph.factorKind(f), [&](auto* tag) {
      rows = std::remove_pointer_t<decltype(tag)>::kErrorDim;
    });
    return rows;
  }
  static void relinearizeBy(FactorGraph<Model>& graph, Index v,
                            const typename FactorGraph<Model>::Delta& delta) {
    graph.relinearizeBy(v, delta);
  }
};

}  // namespace lslam
