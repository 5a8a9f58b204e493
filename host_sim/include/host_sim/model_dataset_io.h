#pragma once
// Readers for every model's file records (2D and 3D poses, 2D and 3D point landmarks; g2o, TORO
// and iSAM) into a ModelDataset, and a g2o writer. Host-only.
//
// Lines, tokens, comments, number and id syntax, format detection and error style are those of
// dataset_io.h: one record per line, tokens separated by blanks or tabs, blank lines and lines
// whose first non-blank character is '#' skipped; numbers strictly parsed and finite, positions,
// translations and ranges within lslam::kMaxCoordinate (1e9 m; for EDGE3 i > j also the inverted
// translation stored), ids integers in 0..2^31-1; every malformed line throws
// DatasetError(file, line, reason), 1-based line.
//
// RECORDS ("sqrt-info": upper-triangular square-root information R, row-major; information R^T R)
//
//   g2o 2D (convention G2o; dimension 2)
//     VERTEX_SE2 id x y theta                  -> ModelVertex SE2 {Pose, id}
//     VERTEX_XY id x y                         -> ModelVertex Point2 {Landmark, id}
//     EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33
//                                              -> BetweenSE2 {Pose i} -> {Pose j}; information
//                                                 from its upper triangle
//     EDGE_SE2_XY pose lm dx dy I11 I12 I22    -> PointXY2 {Pose pose}, {Landmark lm}; z = (dx, dy)
//     EDGE_SE2_RANGE_BEARING pose lm range bearing I11 I12 I22
//                                              -> RangeBearing2 {Pose pose}, {Landmark lm};
//                                                 z = (range, bearing)
//       lslam's own record: g2o has no range-bearing edge (only EDGE_SE2_XY and the bearing-only
//       EDGE_BEARING_SE2_XY). Ids, kinds and field counts as EDGE_SE2_XY. range is the distance
//       from the pose to the landmark, > 0 (a zero range has no bearing); bearing the landmark's
//       angle in radians in the pose's frame, counterclockwise from its x axis, already wrapped:
//       in (-pi, pi], i.e. |bearing| <= 3.141592653589793 (the double nearest pi), else an error at
//       its line (stored as read, never wrapped). The information is over the error, in this
//       order (as model_chi2.h and lslam/factors/landmark_2d_factors.h define it):
//         e = (|d| - range, wrap(atan2(d_y, d_x) - bearing)),   d = R^T (l - t)
//       (e^T Omega e is the same for -e, so (range - |d|, wrap(bearing - atan2)) is equivalent).
//     FIX id [id ...]                          -> ModelDataset::fixed
//   g2o 3D (convention G2o; dimension 3)
//     VERTEX_SE3:QUAT id x y z qx qy qz qw     -> ModelVertex SE3 {Pose, id}, (x y z qx qy qz qw)
//     VERTEX_TRACKXYZ id x y z                 -> ModelVertex Point3 {Landmark, id}
//     EDGE_SE3:QUAT i j x y z qx qy qz qw I11 I12 .. I16 I22 .. I66   (21 upper-triangle entries)
//                                              -> BetweenSE3; information as written: w.r.t.
//                                                 (t, quaternion vector part), g2o's convention
//     EDGE_SE3_TRACKXYZ pose pt param x y z I11 I12 I13 I22 I23 I33   (g2o's EdgeSE3PointXYZ)
//     EDGE_SE3_TRACKXYZ pose pt x y z I11 I12 I13 I22 I23 I33         (same without `param`)
//                                              -> PointXYZ3 {Pose pose}, {Landmark pt}; z = (x y z)
//     PARAMS_SE3OFFSET id x y z qx qy qz qw    (the sensor offset `param` names; g2o computes the
//         point in the frame pose * offset). Only the identity offset is accepted (translation 0,
//         quaternion vector part 0, |qw| within kQuaternionNormTolerance of 1): any other is an
//         error at its line. A `param` must be the id of a PARAMS_SE3OFFSET line above it (as g2o
//         requires). PARAMS lines are checked, not stored.
//     FIX id [id ...]
//   In g2o files poses and landmarks share one id space: ids are unique over all VERTEX_* lines
//   (a VERTEX_XY with the id of a VERTEX_SE2 is a duplicate id), an edge must name vertices of the
//   kinds it connects ("EDGE_SE2_XY names landmark 3, which VERTEX_SE2 at line 2 declares as a
//   pose"), and in files without vertex lines an id may not be used both as a pose and as a
//   landmark. A FIX key takes the role of the vertex with its id (else of the edges using the id,
//   else Pose). A quaternion whose norm differs from 1 by more than kQuaternionNormTolerance is an
//   error at its line ("quaternion norm 1.2 is not 1 (tolerance 1e-05)"); values are stored as
//   read, never normalised.
//
//   TORO 2D (convention G2o; dimension 2): VERTEX2 id x y theta; EDGE2 i j dx dy dtheta inf_xx
//     inf_xy inf_yy inf_thth inf_xth inf_yth, exactly as dataset_io.h reads them (BetweenSE2).
//
//   iSAM (convention Isam; edge-only files: no vertices, no declarations, no FIX)
//     ODOMETRY|EDGE2 i j dx dy dtheta R11 R12 R13 R22 R23 R33
//         -> BetweenSE2 {Pose i} -> {Pose j}, z = (dx, dy, dtheta); information R^T R for
//            e = (x, y, theta) of Xi^-1 Xj minus z, angle wrapped (iSAM's Pose2d_Pose2d_Factor).
//     LANDMARK pose lm dx dy R11 R12 R22
//         -> PointXY2 {Pose pose}, {Landmark lm}; information R^T R for e = Xpose^-1 * l - z
//            (robot frame).
//     POINT3 pose lm x y z R11 R12 R13 R22 R23 R33   (or POINT3 pose lm x y z: R = identity, as
//            iSAM's loader reads it)
//         -> PointXYZ3 {Pose pose}, {Landmark lm}; information R^T R for e = Xpose^-1 * p - z.
//     EDGE3 i j x y z roll pitch yaw S11 S12 .. S16 S22 .. S66   (21 entries; or EDGE3 i j x y z
//            roll pitch yaw: S = identity, as iSAM's loader reads it)
//         -> BetweenSE3, see "EDGE3" below.
//   iSAM gives landmarks (LANDMARK, POINT3) their own id space (its loader maps point ids apart
//   from pose ids: torus2000Points.txt reuses 0..19), so their keys are {Landmark, id} and an id
//   may be both a pose and a landmark. An edge from a pose to itself is an error in every format.
//
// EDGE3 (iSAM 1.x, Kaess et al.; isam/Loader.cpp, isam/Pose3d.h, isam/Rot3d.h, isam/slam3d.h)
//   Angles. The file gives x y z roll pitch yaw (iSAM's loader: "note reverse order of angles").
//   The rotation is yaw about Z, then pitch about the new Y, then roll about the new X:
//     R = Rz(yaw) * Ry(pitch) * Rx(roll)   (maps the measured frame into the base frame)
//   stored as the quaternion iSAM's Rot3d::euler_to_quat computes (not normalised again):
//     qw = cr cp cy + sr sp sy    qx = sr cp cy - cr sp sy
//     qy = cr sp cy + sr cp sy    qz = cr cp sy - sr sp cy    (c/s of roll/2, pitch/2, yaw/2)
//   Evidence: composing the odometry of groundtruth/sphere2500_groundtruth.txt with this
//   convention reproduces all 2450 loop-closure measurements of that file to 2.3e-4 m and 4.3e-6
//   rad (tests/host_sim/test_model_dataset_io.cpp); angles read as yaw pitch roll, or composed
//   X-Y-Z, miss by 163 m / 15 m. The weakest sqrt-information (25 in sphere2500, 100 in torus) is
//   the file's last angle, yaw, as in the g2o copy of sphere2500 (qz).
//   Error (iSAM's Pose3d_Pose3d_Factor::basic_error), the coordinates the information refers to:
//     e = v(Xi^-1 Xj) - v(Z),   v(T) = (x, y, z, yaw, pitch, roll) of T,
//     e(3), e(4), e(5) each wrapped into [-pi, pi) (iSAM's standardRad); e(0..2) is the
//     translation of Xi^-1 Xj (in Xi's frame) minus z's
//   where (yaw, pitch, roll) of a rotation with quaternion (w, x, y, z) are iSAM's
//   Rot3d::quat_to_euler:
//     yaw   = atan2(2 (w z + x y), w^2 + x^2 - y^2 - z^2)
//     pitch = asin(2 (w y - z x))                         (clamp the argument to [-1, 1])
//     roll  = atan2(2 (w x + y z), w^2 - x^2 - y^2 + z^2)
//   For Z these equal the file's angles up to rounding and multiples of 2pi (iSAM uses the file's
//   angles; the wrapping makes them equivalent) because the reader requires |pitch| <= pi/2
//   (1.5707963267948966), rejecting other pitches at their line.
//   Information: Omega = S^T S with S the 6x6 upper-triangular sqrt-information iSAM's loader
//   builds, in the error order (x, y, z, yaw, pitch, roll): with s_ab the file's entries (a, b in
//   the file's order x y z roll pitch yaw, 1-based, a <= b),
//     S = [ s11 s12 s13 s14 s15 s16 ]
//         [  0  s22 s23 s24 s25 s26 ]
//         [  0   0  s33 s34 s35 s36 ]
//         [  0   0   0  s66 s56 s46 ]     <- the rotation block reversed (yaw, pitch, roll)
//         [  0   0   0   0  s55 s45 ]
//         [  0   0   0   0   0  s44 ]
//   The translation-rotation entries s14..s36 keep their file columns (iSAM's loader does so and
//   notes it is "wrong in the presence of off-diagonal entries"); every real file has a diagonal
//   S, where this is just the file's diagonal reordered: sphere2500 (10 10 10 | yaw 25, pitch 100,
//   roll 100), torus2000Points (20 20 100 | yaw 100, pitch 200, roll 200).
//   Direction. iSAM's loader turns an EDGE3 i j with i > j around: it adds the factor j -> i with
//   Z^-1. The reader does the same so that the one formula above is iSAM's objective for every
//   factor: first = {Pose j}, second = {Pose i}, measurement = Z^-1 (quaternion conjugated,
//   translation -R^T t), information S^T S unchanged. (No real file has such an edge.)
//
// FORMAT AND DIMENSION. The tag of each record decides its format as in dataset_io.h (EDGE2 is
// TORO if the file has a VERTEX2 line, a '#' comment line or a ".graph" name, iSAM otherwise) and
// its dimension (FIX: any). A record of another format than the file's first record, or of the
// other dimension, is an error at its line ("record 'EDGE3' is a iSAM record, but the file is read
// as g2o (first g2o record at line 1)", "record 'VERTEX_SE3:QUAT' is a 3D record, but the file is
// 2D (first 2D record at line 1)"). ModelDataset::dimension is that of the records (2 for a file
// without any). Unknown tags: "unsupported record 'X' (...)".
//
// ERRORS besides those of dataset_io.h (wrong field counts, bad numbers and ids, information not
// positive definite per lslam::checkInformation, R^T R overflowing, duplicate vertex ids, an edge
// or FIX naming an id no vertex line declares in a file with vertex lines, reported at the
// earliest offending line): quaternion norm, kinds and roles as described above, EDGE3 pitch,
// EDGE_SE2_RANGE_BEARING range and bearing, PARAMS_SE3OFFSET. A file that cannot be opened or read
// throws DatasetError(path, 0, reason).
#include <iosfwd>
#include <string>

#include "host_sim/model_dataset.h"

namespace lslam::sim {

// Reads a file; ModelDataset::name is `path` as given.
ModelDataset readModelDataset(const std::string& path);

// Parses a stream; `name` is used in error messages, as ModelDataset::name and (its extension)
// for format detection.
ModelDataset parseModelDataset(std::istream& in, const std::string& name);

// Writes g2o records: a "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1" line if there is a PointXYZ3 factor,
// then the vertices (given order: VERTEX_SE2, VERTEX_XY, VERTEX_SE3:QUAT, VERTEX_TRACKXYZ by
// kind), one "FIX id" line per fixed key, then the factors (given order: EDGE_SE2, EDGE_SE2_XY,
// EDGE_SE2_RANGE_BEARING, EDGE_SE3:QUAT, EDGE_SE3_TRACKXYZ pose pt 0 ...), each information as its
// upper triangle.
// Numbers in the shortest form that reads back to the identical double (std::to_chars), so
// write -> parseModelDataset gives the same vertices, factors (kinds, keys, measurements,
// information), fixed keys and dimension (a dataset without vertices and factors reads back as
// 2D); format and convention read back as g2o.
// Throws std::invalid_argument, before writing anything, for what the reader would reject or
// read back differently: a factor kind without a g2o record here (priors); a RangeBearing2 whose
// range is not > 0 or whose bearing is outside (-pi, pi] (not wrapped: written as given); a
// BetweenSE3 of a dataset with convention Isam (its information is in Euler coordinates, see
// EDGE3 above); records of the other dimension than ModelDataset::dimension; a value or
// measurement of the wrong size, non-finite, with a position, translation or range beyond
// lslam::kMaxCoordinate, or a quaternion off unit norm by more than
// kQuaternionNormTolerance; an id outside 0..2^31-1; a pose key with a point kind or the
// reverse; a factor whose two ids are equal; a duplicate vertex id (poses and landmarks share one
// g2o id space), or an id used both as a pose and as a landmark; with vertices, a factor or FIX
// key no vertex of the right kind declares; a fixed key whose role would read back differently;
// an information of the wrong size or whose upper triangle (the symmetric matrix written) is not
// positive definite. std::runtime_error if the stream fails.
void writeModelG2o(std::ostream& out, const ModelDataset& d);
// Writes the dataset to a file (std::runtime_error if the file cannot be written).
void writeModelG2oFile(const std::string& path, const ModelDataset& d);

}  // namespace lslam::sim
