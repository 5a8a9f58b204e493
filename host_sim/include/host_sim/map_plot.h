#pragma once
// The map a person looks at first, as one self-contained SVG document: the estimated trajectory and
// landmarks, the ground truth beside them when given, loop closures as faint lines, axes in metres
// with a scale bar. A 2D dataset gets one panel (x-y); a 3D dataset two side by side, the top view
// (x-y) and the side view (x-z), each with its own axes. Host-only; drawn with svg_writer.h.
//
// What is drawn, in every panel:
//   - the trajectory: one polyline through the poses in id order (class "trajectory-estimate";
//     the truth's, grey and dashed, class "trajectory-truth");
//   - the landmarks: a filled circle each (class "landmark-estimate"), a cross each for the truth
//     (class "landmark-truth");
//   - the loop closures: the between factors whose two pose ids are not consecutive, as one faint
//     path of straight segments between the estimated poses ("M u v L u v" each, class
//     "loop-closures"), at most kMaxLoopClosuresDrawn of them (in factor order; the legend says
//     so when capped);
//   - a frame with ticks at 1, 2 or 5 x 10^k metres, tick labels, axis labels ("x [m]", "y [m]" or
//     "z [m]") and a scale bar. A metre is the same length horizontally and vertically, in every
//     panel.
// Variables without a finite position, or farther than 1e12 m from the origin (a diverged
// estimate), are left out. The truth is drawn as it is: the caller
// expresses it in the estimate's frame first.
//
// Each panel is a <g class="panel" id="panel-xy" | "panel-xz"> carrying its map from metres to
// user units: data-scale (user units per metre), data-origin-x and data-origin-y (where the world
// origin lands), so that (a, b) is drawn at (origin-x + scale a, origin-y - scale b).
#include <cstddef>
#include <string>

#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"

namespace lslam::sim {

inline constexpr std::size_t kMaxLoopClosuresDrawn = 20000;

struct MapPlotInput {
  const ModelDataset* dataset = nullptr;    // required: the factors (loop closures), dimension
  const ModelEstimate* estimate = nullptr;  // required
  const ModelEstimate* truth = nullptr;     // optional, in the estimate's frame
  std::string title;                        // empty: the dataset's name
};

// The whole document. Throws std::invalid_argument if the dataset or the estimate is missing or
// the dataset's dimension is neither 2 nor 3.
std::string renderMapSvg(const MapPlotInput& in);

// renderMapSvg written to `path`; std::runtime_error if the file cannot be written.
void writeMapSvg(const std::string& path, const MapPlotInput& in);

}  // namespace lslam::sim
