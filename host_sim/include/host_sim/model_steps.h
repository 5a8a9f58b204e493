#pragma once
// The order in which `lslam-sim run` feeds a dataset of any model (model_dataset.h) to the
// incremental solver, and the initial values of the variables each step introduces. Host-only;
// independent of firmware_lib (its own small geometry, as model_chi2.h).
//
// STEPS (StepOrder::Online, the order a robot produces the data). The poses are every Pose key of a
// vertex or a factor; they enter in ascending id order (time order in these files), one per step:
// step k introduces the k-th smallest pose id and holds
//   - every BetweenSE2/SE3 whose newer (larger-id) pose is that pose,
//   - every PriorSE2/SE3 on that pose,
//   - every observation (PointXY2, RangeBearing2, PointXYZ3) made from that pose,
//   - every landmark prior (PriorPoint2/3) of a landmark entering in this step,
// in file order among themselves. A landmark enters in the step of its first observation (the
// observation in the earliest step, first in file order within it, which gives its initial value)
// and is listed in that step's new_landmarks in the order of those first observations. Step 0
// introduces the smallest pose id and holds only its priors and observations (often none). Every
// factor appears in exactly one step, and a step's factors reference only variables introduced by
// this or earlier steps.
//
// Landmarks without observations: a landmark that a vertex declares and that has a prior but no
// observation enters in step 0 (after the landmarks observed there, in vertex order) with its
// priors, initialised from its first prior; it is a separate component anchored by its prior.
// (A dataset without poses but with such landmarks gives one step without a pose.)
//
// ERRORS, DatasetError(d.name, line, reason), checked in this order:
//   - a factor with a negative id, with a key of the wrong role for its kind, or a between factor
//     from a pose to itself (its line; the first such factor in file order);
//   - a pose other than the first without a between factor to an older pose and without a prior
//     (the smallest such id; line of its first factor in file order, or of its vertex if it has
//     none: a vertex without factors is an error unless it is the first pose);
//   - a landmark with a prior but no observation that no vertex declares (line of its first
//     prior: a prior on a landmark nothing else names is most likely a wrong id);
//   - a landmark vertex with no factor at all (its vertex line): an unconstrained variable.
// The first pose needs no factor: the solver anchors it.
// An empty dataset (no vertices, no factors) gives no steps. FIX keys are not used, nor are vertex
// values but the first pose's.
//
// FILE ORDER (StepOrder::File, the factors as a stream). Step 0's pose is the first between
// factor's smaller pose (the step holds no pose factor), unless a prior or an observation comes
// first (then it is that factor's pose, with it). Then factors are walked in file order: a between
// factor or prior naming a pose not seen yet starts a step introducing that pose (the step is that
// factor and the following ones until the next new pose); any other factor goes into the current
// (last) step, and a landmark enters there at its first observation or prior (landmark priors
// before the first pose join step 0, which that pose then takes; a file without poses has one step
// without a pose). A factor naming two unknown poses, an observation from an unknown pose, or a
// prior on a landmark nothing observes and no vertex declares throws DatasetError at its line, as
// does a vertex no factor names (at the vertex line). No pose factors: the first pose vertex is
// step 0's pose. intel.g2o, whose edges are listed out of time order, stops at its second edge.
//
// INITIAL VALUES (initialValue). From `current`, the estimate of the variables introduced by
// earlier steps and, for a landmark, of the step's new pose (initialise the pose first):
//   - the new pose: from the first factor of the step, in step order, that is a prior on it (its
//     measurement) or a between factor naming it (online, every between factor of a step links
//     its new pose to an older pose): Xi * Z for a factor stored i -> new, Xj * Z^-1 for one stored
//     new -> j; with neither (the first pose), its vertex's value if the file declares it (the
//     estimate stays in the file's frame), else the identity;
//   - a new landmark: from its first observation in the step, with x the observing pose:
//     PointXY2 / PointXYZ3 t + R z, RangeBearing2 t + R (r cos b, r sin b); a landmark without
//     observation: its first prior's measurement.
// SE2 angles are wrapped to (-pi, pi]; SE3 rotations composed as normalised quaternions. These are
// the rules of initialEstimate (model_chi2.h) for a dataset without vertices whose file order is
// the online order, so chaining initialValue over the steps reproduces it there.
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"
#include "host_sim/steps.h"

namespace lslam::sim {

struct ModelStep {
  VariableKey new_pose{VariableRole::Pose, -1};  // id -1 if none
  std::vector<VariableKey> new_landmarks;        // order of first observation
  std::vector<std::size_t> factors;              // indices into ModelDataset::factors, file order
};

std::vector<ModelStep> buildModelSteps(const ModelDataset& d, StepOrder order = StepOrder::Online);

// The dataset of the first n of `steps` (buildModelSteps of d): their factors, and the vertices of
// their poses and landmarks.
ModelDataset firstSteps(const ModelDataset& d, const std::vector<ModelStep>& steps, std::size_t n);

// The initial value of `key`, a variable `step` introduces (its new pose or one of its
// new_landmarks), in its kind's parameters, from `current` (see INITIAL VALUES above). Throws
// std::invalid_argument if `key` is not introduced by `step`, or a value it needs is missing from
// `current` or has the wrong size.
Eigen::VectorXd initialValue(const ModelDataset& d, const ModelStep& step, const VariableKey& key,
                             const ModelEstimate& current);

}  // namespace lslam::sim
