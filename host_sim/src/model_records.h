#pragma once
// Private to host_sim/src: what the model dataset reader and the g2o writer both know of the
// records: each kind's record name, and the checks a written record must pass to read back as it
// was.
#include <Eigen/Core>
#include <string>

#include "host_sim/dataset.h"
#include "host_sim/model_dataset.h"

namespace lslam::sim::records {

// The record that declares a variable of `kind`, and the one that carries a factor of `kind`, in
// `format` (a factor kind without a record: its name).
const char* vertexTag(VariableKind kind, DatasetFormat format);
const char* factorTag(FactorKind kind, DatasetFormat format);

// Whether an information matrix (2 x 2, 3 x 3 or 6 x 6) is one the solver accepts:
// lslam::checkInformation's test.
bool isPositiveDefinite(const Eigen::MatrixXd& information);

// Why (range, bearing) is not a valid EDGE_SE2_RANGE_BEARING measurement; empty if it is. Both
// are finite here. A zero range is rejected as the factor does (lslam::validateRangeBearingSE2);
// the bearing is not wrapped, so that what is stored is what the file says.
std::string rangeBearingProblem(double range, double bearing);

}  // namespace lslam::sim::records
