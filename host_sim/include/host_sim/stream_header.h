#pragma once
// Turns a 2D pose graph (the PoseSlam2D model, between factors only) into a C++ header that embeds
// its online step stream for target programs (tests/target/pose_graph_stream.cpp), together with
// the host's reference results on that same stream: the incremental run's final estimate and chi2
// (host_sim/model_run.h, defaultModelOptions, solve after every step) and the batch optimum
// (host_sim/model_batch_solver.h, started from the incremental run's initial values, its anchor
// fixed, as lslam-sim does). Host-only.
//
// The header (no dependency but <cstdint>, constexpr arrays in flash on the target):
//   kSteps[]      one per online step: new pose id, its factors' range in kFactors, and whether
//                 the step closes a loop (host_sim's StepKind::LoopClosure);
//   kFactors[]    every measurement in step order: from, to, (x, y, theta), information (as the
//                 solver takes it, solverInformation) as its upper triangle I11 I12 I13 I22 I23 I33;
//   kFirstPose    the initial value of step 0's pose (the others are initialised on the fly from
//                 the current estimate and the step's first factor, as the host runner does);
//   kHostIncrementalChi2, kHostIncrementalPoses[], kBatchChi2, kBatchPoses[] (poses by id).
// Doubles are written in their shortest round-trip form, so the header holds the host's values
// bit for bit and generating it twice gives the same text.
#include <string>

#include "host_sim/model_dataset.h"

namespace lslam::sim {

// `source_name` is quoted in the header's comment; `name_space` is the namespace inside
// lslam::stream holding the arrays (a C++ identifier). Throws std::invalid_argument for a dataset
// that is not a 2D pose graph of between factors, ids outside 0..2^31-1 or a name_space that is
// not an identifier, and whatever buildModelSteps, runModelIncremental or solveModelBatch throw.
std::string streamHeader(const ModelDataset& d, const std::string& source_name,
                         const std::string& name_space);

}  // namespace lslam::sim
