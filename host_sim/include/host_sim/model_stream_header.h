#pragma once
// Turns a 3D dataset with point landmarks (the Slam3D model) into a C++ header that embeds its
// online step stream for target programs (tests/target/model_stream.cpp), with the host's
// reference results on it: the counterpart of stream_header.h for StaticSmoother<Slam3D, ...>.
// Host-only.
//
// The stream is exactly what runModelIncremental (model_run.h; IncrementalOptions{} with solver
// options defaultModelOptions(d)) feeds its solver, bit for bit: each variable's initial value as
// that run computed it (ModelRun::initial) and each factor's measurement and information as the
// solver's inputs hold them (quaternions normalised, information from solverInformation). The
// target copies them into ModelVariableInput / ModelFactorInput unchanged.
//
// The header (no dependency but <cstdint>, constexpr arrays in flash on the target):
//   kSteps[]      one per online step: its variables' range in kVariables, its factors' range in
//                 kFactors, whether it closes a loop (a between factor to a pose other than the
//                 previous one) and whether it observes a landmark;
//   kVariables[]  kind (0 SE3 pose, 1 Point3 landmark), id, ModelVariableInput<Slam3D>::value;
//   kFactors[]    kind (0 BetweenSE3, 1 PointObservationSE3), ids, ModelFactorInput::measurement,
//                 the information's upper triangle row by row (21 entries for 6x6, 6 for 3x3);
//   kHostIncrementalChi2 (host_sim's chi2 of the run's final estimate), kHostIncrementalValues[]
//   (that estimate: kind, id, x y z qx qy qz qw or x y z), kBatchChi2 (solveModelBatch from the
//   run's initial values, the anchor fixed, as lslam-sim does).
// Doubles are written in their shortest round-trip form.
#include <string>

#include "host_sim/model_dataset.h"

namespace lslam::sim {

// `source_name` is quoted in the header's comment; `name_space` is the namespace inside
// lslam::stream (a C++ identifier). Throws std::invalid_argument for a dataset that is not 3D with
// landmarks, ids outside 0..2^31-1, an information that is not exactly symmetric, or a name_space
// that is not an identifier; and whatever runModelIncremental or solveModelBatch throw.
std::string modelStreamHeader(const ModelDataset& d, const std::string& source_name,
                              const std::string& name_space);

}  // namespace lslam::sim
