#pragma once
// How the solver's units see the graph they work on: PoseGraph2D (one kind of variable, SE2, with
// the whitened rows of the row update) or FactorGraph<Model> (the model's kinds; the whitened rows
// for a model of one block size).
// The units are templates over the graph and the factor, compiled once per pair in their sources.
#include "lslam/factors/pose_graph_2d.h"
#include "lslam/graph/factor_graph.h"
#include "lslam/linear/incremental_cholesky.h"
#include "lslam/linear/index.h"

namespace lslam {

// Per graph type: the number of variable kinds, whether it offers the row update's whitened rows,
// a variable's kind and degrees of freedom, and the
// relinearization of a variable at its linearization point moved by its solution delta.
template <class Graph>
struct GraphAdapter;

template <>
struct GraphAdapter<PoseGraph2D> {
  static constexpr int kKinds = 1;
  static constexpr bool kWhitenedRows = true;
  static int kindOf(const PoseGraph2D& /*graph*/, Index /*v*/) { return 0; }
  static int dofOfKind(int /*kind*/) { return 3; }
  static void relinearizeBy(PoseGraph2D& graph, Index v, const Vec3& delta) {
    graph.relinearize(v, graph.linearizationPoint(v).retract(delta));
  }
};

template <class Model>
struct GraphAdapter<FactorGraph<Model>> {
  static constexpr int kKinds = Model::Variables::kSize;
  static constexpr bool kWhitenedRows = FactorGraph<Model>::kWhitenedRows;
  static int kindOf(const FactorGraph<Model>& graph, Index v) { return graph.variableKind(v); }
  static int dofOfKind(int kind) { return ModelBlockSizes<Model>::sizeOfKind(kind); }
  static void relinearizeBy(FactorGraph<Model>& graph, Index v,
                            const typename FactorGraph<Model>::Delta& delta) {
    graph.relinearizeBy(v, delta);
  }
};

// The row update (IncrementalCholesky::addFactorRows) is compiled for one block size only, and
// needs the graph's whitened rows; elsewhere an update that only adds factors recomputes.
template <class Graph, class Factor>
inline constexpr bool kRowUpdates = Factor::kUniform&& GraphAdapter<Graph>::kWhitenedRows;

}  // namespace lslam
