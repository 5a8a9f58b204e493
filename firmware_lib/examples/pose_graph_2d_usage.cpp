// lslam in firmware: a robot drives a 4 m square, one pose per metre, with a gyro that overturns
// every corner, and sees its start again. The tests run it on the host and on the Cortex-M7.
#include "lslam/models/pose_slam_2d.h"
#include "lslam/solver/smoother.h"

using namespace lslam;
using Pose = ModelVariableInput<PoseSlam2D>;
using Measurement = ModelFactorInput<PoseSlam2D>;

namespace {
// Capacities are compile-time: poses, landmarks (none in a pose graph), measurements and their
// doubles (12 per SE2 measurement), 3x3 blocks of the factor (leave about twice the expected
// fill) and their doubles (0: with one block size the blocks hold them). Static, so its memory is
// in .bss; update() never allocates.
StaticSmoother<PoseSlam2D, 64, 0, 128, 128 * 12, 2048, 0> solver;

// Pose `id`, seen by odometry from pose id - 1 (and, if `loop`, pose 0 seen from it again).
Status addStep(VariableId id, const SE2& odometry, bool loop) {
  const Mat3 information = Vec3(100.0, 100.0, 400.0).asDiagonal();  // sigma 10 cm, 0.05 rad
  SE2 previous;
  const Status known = solver.estimate(id - 1, &previous);
  if (known != Status::Ok) return known;                         // UnknownVariable
  const Pose pose = Pose::make(id, previous.compose(odometry));  // initial guess: dead reckoning
  const Measurement factors[2] = {
      Measurement::make<BetweenSE2Factor>(id - 1, id, odometry, information),
      Measurement::make<BetweenSE2Factor>(id, 0, SE2(), information)};
  return solver.update(&pose, 1, factors, loop ? 2 : 1);  // also back-substitutes
}
}  // namespace

int main() {
  const Pose origin = Pose::make(0, SE2());  // the first pose fixes the map's frame
  if (solver.update(&origin, 1, nullptr, 0) != Status::Ok) return 1;
  const double turn = 1.5707963267948966 + 0.05;  // 90 degrees, overturned by 0.05 rad
  SE2 dead_reckoning;
  for (VariableId id = 1; id <= 16; ++id) {
    const SE2 odometry(1.0, 0.0, id % 4 == 0 ? turn : 0.0);
    dead_reckoning = dead_reckoning.compose(odometry);
    // Anything but Ok changed nothing; toString(status) says why (NaN, information not positive
    // definite, unknown id, ...). CapacityExhausted: the map is full, a larger solver is needed.
    if (addStep(id, odometry, id == 16) != Status::Ok) return 2;
  }
  SE2 end;  // pose 16 is back at the origin: the estimate, corrected by the loop closure
  if (solver.estimate(16, &end) != Status::Ok) return 3;
  return end.translation().norm() < 0.2 * dead_reckoning.translation().norm() ? 0 : 4;
}
