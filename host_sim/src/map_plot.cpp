#include "host_sim/map_plot.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "host_sim/svg_writer.h"

namespace lslam::sim {
namespace {

constexpr const char* kEstimateColour = "#1f5fbf";
constexpr const char* kLandmarkColour = "#d6452b";
constexpr const char* kTruthColour = "#707070";
constexpr const char* kLoopColour = "#c2185b";
constexpr const char* kTruthDash = "6 4";

// The page: margins and the bands around each panel's frame, in user units.
constexpr double kMargin = 20;
constexpr double kLegendBaseline = 52;
constexpr double kPanelsTop = 70;
constexpr double kPanelTitleBand = 22;
constexpr double kLeftGutter = 64;
constexpr double kBottomGutter = 66;
constexpr double kPanelGap = 30;
constexpr double kCharWidth = 7;     // of 12-unit sans-serif text, roughly, for the layout
constexpr double kTickSpacing = 90;  // the tick spacing aimed at along an axis
constexpr double kTickLength = 5;

using Point = Eigen::Vector3d;  // z = 0 in 2D

// Positions farther out are left out with the non-finite ones: a diverged estimate still plots.
constexpr double kFarthest = 1e12;
// The smallest span a view shows, in metres.
constexpr double kSmallestSpan = 1e-3;

struct Placed {
  std::int64_t id;
  Point p;
};

// The variables of one estimate with a finite position, each role in id order.
struct Layer {
  std::vector<Placed> poses;
  std::vector<Placed> landmarks;
};

Layer collectLayer(const ModelEstimate& values, int dimension) {
  Layer layer;
  for (const auto& [key, value] : values) {
    if (value.size() < dimension) continue;
    Point p = Point::Zero();
    p.head(dimension) = value.head(dimension);
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > kFarthest) continue;
    (key.role == VariableRole::Pose ? layer.poses : layer.landmarks).push_back({key.id, p});
  }
  const auto byId = [](const Placed& x, const Placed& y) { return x.id < y.id; };
  std::sort(layer.poses.begin(), layer.poses.end(), byId);
  std::sort(layer.landmarks.begin(), layer.landmarks.end(), byId);
  return layer;
}

const Point* findPose(const Layer& layer, std::int64_t id) {
  const auto it = std::lower_bound(layer.poses.begin(), layer.poses.end(), id,
                                   [](const Placed& x, std::int64_t i) { return x.id < i; });
  return it != layer.poses.end() && it->id == id ? &it->p : nullptr;
}

bool isLoopClosure(const ModelFactor& f) {
  const bool between = f.kind == FactorKind::BetweenSE2 || f.kind == FactorKind::BetweenSE3;
  return between && f.first.role == VariableRole::Pose && f.second.role == VariableRole::Pose &&
         f.first.id != f.second.id + 1 && f.second.id != f.first.id + 1;
}

// The loop closures between estimated poses: the first kMaxLoopClosuresDrawn, and how many.
struct LoopClosures {
  std::vector<std::pair<Point, Point>> drawn;
  std::size_t total = 0;
};

LoopClosures collectLoopClosures(const ModelDataset& d, const Layer& estimate) {
  LoopClosures loops;
  for (const ModelFactor& f : d.factors) {
    if (!isLoopClosure(f)) continue;
    const Point* a = findPose(estimate, f.first.id);
    const Point* b = findPose(estimate, f.second.id);
    if (a == nullptr || b == nullptr) continue;
    ++loops.total;
    if (loops.drawn.size() < kMaxLoopClosuresDrawn) loops.drawn.emplace_back(*a, *b);
  }
  return loops;
}

struct Scene {
  Layer estimate;
  Layer truth;
  bool has_truth = false;
  LoopClosures loops;
};

// A panel: the two coordinates it shows, horizontally (a) and vertically (b).
struct View {
  int a;
  int b;
  const char* id;
  const char* title;  // empty: none (the single panel of a 2D map)
  const char* label_a;
  const char* label_b;
};
constexpr View kPlaneView{0, 1, "panel-xy", "", "x [m]", "y [m]"};
constexpr View kTopView{0, 1, "panel-xy", "top view (x-y)", "x [m]", "y [m]"};
constexpr View kSideView{0, 2, "panel-xz", "side view (x-z)", "x [m]", "z [m]"};

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return lo > hi; }
  double span() const { return empty() ? 0.0 : hi - lo; }
  // Grows the range about its centre to at least `width`.
  void widen(double width) {
    const double centre = empty() ? 0.0 : 0.5 * (lo + hi);
    const double half = 0.5 * std::max(width, span());
    lo = centre - half;
    hi = centre + half;
  }
};

struct Extent {
  Range a;
  Range b;
};

void addLayer(Extent& e, const View& v, const Layer& layer) {
  for (const auto* group : {&layer.poses, &layer.landmarks}) {
    for (const Placed& x : *group) {
      e.a.add(x.p[v.a]);
      e.b.add(x.p[v.b]);
    }
  }
}

// The metres a view shows: everything drawn, each axis at least a fifth of the other (a flat side
// view stays readable), a margin of 5 % of the larger span around; [-1, 1] when nothing is drawn,
// kSmallestSpan when everything is (nearly) at one point.
Extent viewExtent(const View& v, const Scene& s) {
  Extent e;
  addLayer(e, v, s.estimate);
  if (s.has_truth) addLayer(e, v, s.truth);
  const double larger = e.a.empty() ? 2.0 : std::max({e.a.span(), e.b.span(), kSmallestSpan});
  e.a.widen(0.2 * larger);
  e.b.widen(0.2 * larger);
  e.a.widen(e.a.span() + 0.1 * larger);
  e.b.widen(e.b.span() + 0.1 * larger);
  return e;
}

// Where a view's frame lies on the page and its map from metres to user units.
struct Frame {
  double left = 0;
  double top = 0;
  double scale = 1;  // user units per metre, both axes
  Extent extent;
  double u(double a) const { return left + (a - extent.a.lo) * scale; }
  double v(double b) const { return top + (extent.b.hi - b) * scale; }
  double width() const { return extent.a.span() * scale; }
  double height() const { return extent.b.span() * scale; }
};

// 1, 2 or 5 x 10^k: the smallest at least `raw` (roundUp) or the largest at most `raw`.
double niceValue(double raw, bool round_up) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double up[] = {1, 2, 5, 10};
  const double down[] = {10, 5, 2, 1};
  for (const double m : round_up ? up : down) {
    if (round_up ? m * magnitude >= raw * (1 - 1e-9) : m * magnitude <= raw * (1 + 1e-9)) {
      return m * magnitude;
    }
  }
  return magnitude;
}

int decimalsOf(double step) {
  return std::clamp(static_cast<int>(-std::floor(std::log10(step) + 1e-9)), 0, 9);
}

// The ticks of an axis: multiples of a nice step, about kTickSpacing user units apart.
struct Ticks {
  double step = 1;
  std::vector<double> values;
  std::string label(double value) const { return formatSvgNumber(value, decimalsOf(step)); }
};

// The ticks of a range `length` user units long.
Ticks ticksOf(const Range& r, double length) {
  Ticks t;
  t.step = niceValue(r.span() / std::max(2.0, std::floor(length / kTickSpacing)), true);
  const double first = std::ceil(r.lo / t.step - 1e-9);
  const double last = std::floor(r.hi / t.step + 1e-9);
  for (double k = first; k <= last; ++k) t.values.push_back(k * t.step);
  return t;
}

std::string xy(double u, double v) {
  return formatSvgNumber(u) + "," + formatSvgNumber(v);
}

std::string moveLine(double u0, double v0, double u1, double v1) {
  return "M" + formatSvgNumber(u0) + " " + formatSvgNumber(v0) + "L" + formatSvgNumber(u1) + " " +
         formatSvgNumber(v1);
}

void drawGrid(SvgWriter& w, const Frame& f, const Ticks& ta, const Ticks& tb) {
  std::string d;
  for (const double t : ta.values) d += moveLine(f.u(t), f.top, f.u(t), f.top + f.height());
  for (const double t : tb.values) d += moveLine(f.left, f.v(t), f.left + f.width(), f.v(t));
  if (d.empty()) return;
  w.element("path", {{"class", "grid"}, {"d", d}, {"stroke", "#e6e6e6"}, {"fill", "none"}});
}

void drawTicks(SvgWriter& w, const Frame& f, const Ticks& ta, const Ticks& tb) {
  const double bottom = f.top + f.height();
  std::string d;
  for (const double t : ta.values) d += moveLine(f.u(t), bottom, f.u(t), bottom + kTickLength);
  for (const double t : tb.values) d += moveLine(f.left - kTickLength, f.v(t), f.left, f.v(t));
  if (!d.empty()) w.element("path", {{"class", "ticks"}, {"d", d}, {"stroke", "#000"}});
  for (const double t : ta.values) {
    w.text(
        "text",
        {{"class", "tick-label-a"}, {"x", f.u(t)}, {"y", bottom + 18}, {"text-anchor", "middle"}},
        ta.label(t));
  }
  for (const double t : tb.values) {
    w.text(
        "text",
        {{"class", "tick-label-b"}, {"x", f.left - 8}, {"y", f.v(t) + 4}, {"text-anchor", "end"}},
        tb.label(t));
  }
}

void drawAxisLabels(SvgWriter& w, const Frame& f, const View& v) {
  const double cu = f.left + 0.5 * f.width();
  const double cv = f.top + 0.5 * f.height();
  w.text("text",
         {{"class", "axis-label"},
          {"x", cu},
          {"y", f.top + f.height() + 36},
          {"text-anchor", "middle"}},
         v.label_a);
  const double lu = f.left - kLeftGutter + 14;
  w.text("text",
         {{"class", "axis-label"},
          {"x", lu},
          {"y", cv},
          {"text-anchor", "middle"},
          {"transform", "rotate(-90 " + xy(lu, cv) + ")"}},
         v.label_b);
}

// A bar of a nice length up to a quarter of the frame's width, under its left end.
void drawScaleBar(SvgWriter& w, const Frame& f) {
  const double metres = niceValue(0.25 * f.extent.a.span(), false);
  const double u0 = f.left;
  const double u1 = f.left + metres * f.scale;
  const double v = f.top + f.height() + 52;
  w.open("g", {{"class", "scale-bar"}});
  w.element("path", {{"d", moveLine(u0, v - 4, u0, v) + moveLine(u0, v, u1, v) +
                               moveLine(u1, v, u1, v - 4)},
                     {"stroke", "#000"},
                     {"stroke-width", 1.5},
                     {"fill", "none"}});
  w.text("text", {{"x", u1 + 6}, {"y", v + 4}}, formatSvgNumber(metres, decimalsOf(metres)) + " m");
  w.close();
}

void drawLoopClosures(SvgWriter& w, const Frame& f, const View& v, const LoopClosures& loops) {
  if (loops.drawn.empty()) return;
  std::string d;
  for (const auto& [a, b] : loops.drawn)
    d += moveLine(f.u(a[v.a]), f.v(a[v.b]), f.u(b[v.a]), f.v(b[v.b]));
  w.element("path", {{"class", "loop-closures"},
                     {"d", d},
                     {"stroke", kLoopColour},
                     {"stroke-opacity", 0.3},
                     {"stroke-width", 0.6},
                     {"fill", "none"}});
}

void drawTrajectory(SvgWriter& w, const Frame& f, const View& v, const Layer& layer, bool truth) {
  if (layer.poses.empty()) return;
  std::string points;
  for (const Placed& x : layer.poses) {
    if (!points.empty()) points += ' ';
    points += xy(f.u(x.p[v.a]), f.v(x.p[v.b]));
  }
  SvgAttributes a{{"class", truth ? "trajectory-truth" : "trajectory-estimate"},
                  {"points", points},
                  {"fill", "none"},
                  {"stroke", truth ? kTruthColour : kEstimateColour},
                  {"stroke-width", truth ? 1.2 : 1.6},
                  {"stroke-linejoin", "round"}};
  if (truth) a.emplace_back("stroke-dasharray", kTruthDash);
  w.element("polyline", a);
}

std::string crossPath(double u, double v) {
  return "M" + xy(u - 3, v - 3) + "l6,6m0,-6l-6,6";
}

void drawLandmarks(SvgWriter& w, const Frame& f, const View& v, const Layer& layer, bool truth) {
  if (layer.landmarks.empty()) return;
  if (truth) {
    w.open("g", {{"stroke", kTruthColour}, {"stroke-width", 1.2}, {"fill", "none"}});
  } else {
    w.open("g", {{"fill", kLandmarkColour}});
  }
  for (const Placed& x : layer.landmarks) {
    const double u = f.u(x.p[v.a]);
    const double vv = f.v(x.p[v.b]);
    if (truth) {
      w.element("path", {{"class", "landmark-truth"}, {"d", crossPath(u, vv)}});
    } else {
      w.element("circle", {{"class", "landmark-estimate"}, {"cx", u}, {"cy", vv}, {"r", 2.5}});
    }
  }
  w.close();
}

void drawPanel(SvgWriter& w, const Frame& f, const View& v, const Scene& s) {
  w.open("g", {{"class", "panel"},
               {"id", v.id},
               {"data-scale", formatSvgNumber(f.scale, 6)},
               {"data-origin-x", formatSvgNumber(f.u(0), 6)},
               {"data-origin-y", formatSvgNumber(f.v(0), 6)}});
  if (*v.title != '\0') {
    w.text("text",
           {{"class", "panel-title"}, {"x", f.left}, {"y", f.top - 8}, {"font-weight", "bold"}},
           v.title);
  }
  const Ticks ta = ticksOf(f.extent.a, f.width());
  const Ticks tb = ticksOf(f.extent.b, f.height());
  drawGrid(w, f, ta, tb);
  drawLoopClosures(w, f, v, s.loops);
  if (s.has_truth) {
    drawTrajectory(w, f, v, s.truth, true);
    drawLandmarks(w, f, v, s.truth, true);
  }
  drawTrajectory(w, f, v, s.estimate, false);
  drawLandmarks(w, f, v, s.estimate, false);
  w.element("rect", {{"class", "frame"},
                     {"x", f.left},
                     {"y", f.top},
                     {"width", f.width()},
                     {"height", f.height()},
                     {"fill", "none"},
                     {"stroke", "#000"}});
  drawTicks(w, f, ta, tb);
  drawAxisLabels(w, f, v);
  drawScaleBar(w, f);
  w.close();
}

// The frames of the views side by side, one scale for all: the largest at which every frame fits
// in `max_width` x `max_height`.
std::vector<Frame> layoutFrames(const std::vector<View>& views, const Scene& s, double max_width,
                                double max_height) {
  std::vector<Frame> frames;
  double scale = std::numeric_limits<double>::infinity();
  for (const View& v : views) {
    Frame f;
    f.extent = viewExtent(v, s);
    scale = std::min({scale, max_width / f.extent.a.span(), max_height / f.extent.b.span()});
    frames.push_back(f);
  }
  double left = kMargin;
  for (Frame& f : frames) {
    f.scale = scale;
    f.left = left + kLeftGutter;
    f.top = kPanelsTop + kPanelTitleBand;
    left = f.left + f.width() + kPanelGap;
  }
  return frames;
}

// One entry of the legend: a sample of how it is drawn and its name.
enum class Sample { Estimate, Truth, Landmark, TruthLandmark, Loop };
struct LegendEntry {
  Sample sample;
  std::string name;
};

std::vector<LegendEntry> legendEntries(const Scene& s) {
  std::vector<LegendEntry> entries{{Sample::Estimate, "estimate"}};
  if (s.has_truth) entries.push_back({Sample::Truth, "ground truth"});
  if (!s.estimate.landmarks.empty()) entries.push_back({Sample::Landmark, "landmarks (estimate)"});
  if (s.has_truth && !s.truth.landmarks.empty()) {
    entries.push_back({Sample::TruthLandmark, "landmarks (ground truth)"});
  }
  const std::size_t drawn = s.loops.drawn.size();
  if (drawn == s.loops.total && drawn > 0) {
    entries.push_back({Sample::Loop, "loop closures (" + std::to_string(drawn) + ")"});
  } else if (drawn < s.loops.total) {
    entries.push_back({Sample::Loop, "loop closures (first " + std::to_string(drawn) + " of " +
                                         std::to_string(s.loops.total) + " drawn)"});
  }
  return entries;
}

constexpr double kSampleWidth = 24;
double entryWidth(const LegendEntry& e) {
  return kSampleWidth + 6 + kCharWidth * static_cast<double>(e.name.size()) + 18;
}

void drawSample(SvgWriter& w, Sample sample, double u, double v) {
  const std::string line = moveLine(u, v, u + kSampleWidth, v);
  const double cu = u + 0.5 * kSampleWidth;
  switch (sample) {
    case Sample::Estimate:
      w.element("path", {{"d", line}, {"stroke", kEstimateColour}, {"stroke-width", 1.6}});
      break;
    case Sample::Truth:
      w.element("path", {{"d", line}, {"stroke", kTruthColour}, {"stroke-dasharray", kTruthDash}});
      break;
    case Sample::Landmark:
      w.element("circle", {{"cx", cu}, {"cy", v}, {"r", 2.5}, {"fill", kLandmarkColour}});
      break;
    case Sample::TruthLandmark:
      w.element("path", {{"d", crossPath(cu, v)}, {"stroke", kTruthColour}, {"fill", "none"}});
      break;
    case Sample::Loop:
      w.element("path", {{"d", line}, {"stroke", kLoopColour}, {"stroke-opacity", 0.5}});
      break;
  }
}

void drawLegend(SvgWriter& w, const std::vector<LegendEntry>& entries) {
  w.open("g", {{"class", "legend"}});
  double u = kMargin;
  for (const LegendEntry& e : entries) {
    drawSample(w, e.sample, u, kLegendBaseline - 4);
    w.text("text", {{"x", u + kSampleWidth + 6}, {"y", kLegendBaseline}}, e.name);
    u += entryWidth(e);
  }
  w.close();
}

Scene makeScene(const MapPlotInput& in) {
  Scene s;
  const int dim = in.dataset->dimension;
  s.estimate = collectLayer(*in.estimate, dim);
  s.has_truth = in.truth != nullptr;
  if (s.has_truth) s.truth = collectLayer(*in.truth, dim);
  s.loops = collectLoopClosures(*in.dataset, s.estimate);
  return s;
}

void checkInput(const MapPlotInput& in) {
  if (in.dataset == nullptr) throw std::invalid_argument("renderMapSvg: no dataset");
  if (in.estimate == nullptr) throw std::invalid_argument("renderMapSvg: no estimate");
  if (in.dataset->dimension != 2 && in.dataset->dimension != 3) {
    throw std::invalid_argument("renderMapSvg: dimension " + std::to_string(in.dataset->dimension) +
                                " is neither 2 nor 3");
  }
}

}  // namespace

std::string renderMapSvg(const MapPlotInput& in) {
  checkInput(in);
  const Scene scene = makeScene(in);
  const bool three_d = in.dataset->dimension == 3;
  const std::vector<View> views =
      three_d ? std::vector<View>{kTopView, kSideView} : std::vector<View>{kPlaneView};
  const std::vector<Frame> frames =
      three_d ? layoutFrames(views, scene, 560, 560) : layoutFrames(views, scene, 820, 620);
  const std::vector<LegendEntry> legend = legendEntries(scene);
  const std::string title = in.title.empty() ? in.dataset->name : in.title;

  double legend_width = 0;
  for (const LegendEntry& e : legend) legend_width += entryWidth(e);
  double panels_bottom = 0;
  for (const Frame& f : frames) panels_bottom = std::max(panels_bottom, f.top + f.height());
  const double width =
      std::max({frames.back().left + frames.back().width() + kMargin, legend_width + 2 * kMargin,
                kCharWidth * 1.4 * static_cast<double>(title.size()) + 2 * kMargin});
  SvgWriter w(std::ceil(width), std::ceil(panels_bottom + kBottomGutter));
  w.element("rect", {{"width", "100%"}, {"height", "100%"}, {"fill", "#fff"}});
  w.open("g", {{"font-family", "sans-serif"}, {"font-size", 12}});
  w.text("text", {{"class", "title"}, {"x", kMargin}, {"y", 28}, {"font-size", 18}}, title);
  drawLegend(w, legend);
  for (std::size_t i = 0; i < views.size(); ++i) drawPanel(w, frames[i], views[i], scene);
  return w.finish();
}

void writeMapSvg(const std::string& path, const MapPlotInput& in) {
  const std::string svg = renderMapSvg(in);
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("writeMapSvg: cannot open '" + path + "' for writing");
  out << svg;
  out.flush();
  if (!out) throw std::runtime_error("writeMapSvg: write to '" + path + "' failed");
}

}  // namespace lslam::sim
