// Tests of the SVG map (host_sim/map_plot.h): every document is read back by a minimal XML reader
// written here (balanced tags, quoted attributes, entities only where escaping needs them, one
// <svg> root), then its elements are counted and the trajectories mapped back to metres through
// each panel's scale and origin.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "host_sim/map_plot.h"
#include "model_test_support.h"

using lslam::sim::FactorKind;
using lslam::sim::kMaxLoopClosuresDrawn;
using lslam::sim::MapPlotInput;
using lslam::sim::ModelDataset;
using lslam::sim::ModelEstimate;
using lslam::sim::renderMapSvg;
using lslam::sim::Vector7d;
using lslam::sim::writeMapSvg;
using lslam::sim::test::factor;
using lslam::sim::test::landmark;
using lslam::sim::test::pose;

namespace {

// ---- A minimal XML reader --------------------------------------------------------------------

struct XmlNode {
  std::string name;
  std::map<std::string, std::string> attributes;  // unescaped
  std::vector<XmlNode> children;
  std::string text;  // the character data directly inside, unescaped
};

// Reads one document or throws std::runtime_error at the first thing not well-formed. Stricter
// than XML where the writer promises more: > " ' must be escaped too, and only the five named
// entities are accepted.
class XmlReader {
 public:
  explicit XmlReader(std::string_view s) : s_(s) {}

  XmlNode document() {
    if (startsWith("<?xml")) {
      const std::size_t end = s_.find("?>");
      if (end == std::string_view::npos) fail("unterminated XML declaration");
      pos_ = end + 2;
    }
    skipSpace();
    XmlNode root = element();
    skipSpace();
    if (pos_ != s_.size()) fail("content after the root element");
    return root;
  }

 private:
  [[noreturn]] void fail(const std::string& why) const {
    throw std::runtime_error(why + " at offset " + std::to_string(pos_));
  }
  bool startsWith(std::string_view p) const { return s_.substr(pos_, p.size()) == p; }
  char peek() const {
    if (pos_ >= s_.size()) fail("unexpected end");
    return s_[pos_];
  }
  void expect(char c) {
    if (peek() != c) fail(std::string("expected '") + c + "'");
    ++pos_;
  }
  bool skipSpace() {
    const std::size_t start = pos_;
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    return pos_ > start;
  }
  std::string name() {
    const std::size_t start = pos_;
    const auto ok = [](char c, bool first) {
      return std::isalpha(static_cast<unsigned char>(c)) || c == '_' ||
             (!first && (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == ':'));
    };
    while (pos_ < s_.size() && ok(s_[pos_], pos_ == start)) ++pos_;
    if (pos_ == start) fail("expected a name");
    return std::string(s_.substr(start, pos_ - start));
  }
  std::string unescape(std::string_view raw) const {
    static const std::map<std::string, char> kEntities{
        {"amp", '&'}, {"lt", '<'}, {"gt", '>'}, {"quot", '"'}, {"apos", '\''}};
    std::string out;
    for (std::size_t i = 0; i < raw.size(); ++i) {
      if (std::string_view("<>\"'").find(raw[i]) != std::string_view::npos) {
        fail(std::string("unescaped ") + raw[i]);
      }
      if (raw[i] != '&') {
        out += raw[i];
        continue;
      }
      const std::size_t semi = raw.find(';', i);
      if (semi == std::string_view::npos) fail("unterminated entity");
      const auto it = kEntities.find(std::string(raw.substr(i + 1, semi - i - 1)));
      if (it == kEntities.end()) fail("unknown entity");
      out += it->second;
      i = semi;
    }
    return out;
  }
  void attribute(XmlNode& node) {
    const std::string key = name();
    expect('=');
    const char quote = peek();
    if (quote != '"' && quote != '\'') fail("unquoted attribute value");
    ++pos_;
    const std::size_t end = s_.find(quote, pos_);
    if (end == std::string_view::npos) fail("unterminated attribute value");
    const std::string value = unescape(s_.substr(pos_, end - pos_));
    pos_ = end + 1;
    if (!node.attributes.emplace(key, value).second) fail("duplicate attribute " + key);
  }
  // The start tag's attributes; true if the element is empty (<tag/>).
  bool startTag(XmlNode& node) {
    for (;;) {
      const bool spaced = skipSpace();
      if (startsWith("/>")) {
        pos_ += 2;
        return true;
      }
      if (peek() == '>') {
        ++pos_;
        return false;
      }
      if (!spaced) fail("no space before an attribute");
      attribute(node);
    }
  }
  XmlNode element() {
    expect('<');
    XmlNode node;
    node.name = name();
    if (startTag(node)) return node;
    for (;;) {
      if (startsWith("</")) {
        pos_ += 2;
        if (name() != node.name) fail("mismatched end tag of " + node.name);
        skipSpace();
        expect('>');
        return node;
      }
      if (peek() == '<') {
        node.children.push_back(element());
        continue;
      }
      const std::size_t end = s_.find('<', pos_);
      if (end == std::string_view::npos) fail("unclosed element " + node.name);
      node.text += unescape(s_.substr(pos_, end - pos_));
      pos_ = end;
    }
  }

  std::string_view s_;
  std::size_t pos_ = 0;
};

// The document read back, with the root checked: <svg> in the SVG namespace with a size.
XmlNode readSvg(const std::string& svg) {
  XmlNode root;
  try {
    root = XmlReader(svg).document();
  } catch (const std::runtime_error& e) {
    FAIL("not well-formed: " << e.what());
  }
  CHECK(root.name == "svg");
  CHECK(root.attributes["xmlns"] == "http://www.w3.org/2000/svg");
  for (const char* key : {"viewBox", "width", "height"}) CHECK(root.attributes.count(key) == 1);
  return root;
}

// ---- Queries -----------------------------------------------------------------------------------

void collect(const XmlNode& n, const std::function<bool(const XmlNode&)>& match,
             std::vector<const XmlNode*>& out) {
  if (match(n)) out.push_back(&n);
  for (const XmlNode& c : n.children) collect(c, match, out);
}

std::string attr(const XmlNode& n, const std::string& key) {
  const auto it = n.attributes.find(key);
  REQUIRE_MESSAGE(it != n.attributes.end(), n.name << " has no " << key);
  return it->second;
}

std::vector<const XmlNode*> byClass(const XmlNode& root, const std::string& cls) {
  std::vector<const XmlNode*> out;
  collect(
      root,
      [&](const XmlNode& n) {
        const auto it = n.attributes.find("class");
        return it != n.attributes.end() && it->second == cls;
      },
      out);
  return out;
}

const XmlNode& panel(const XmlNode& root, const std::string& id) {
  std::vector<const XmlNode*> found;
  collect(
      root, [&](const XmlNode& n) { return n.attributes.count("id") && attr(n, "id") == id; },
      found);
  REQUIRE(found.size() == 1);
  CHECK(attr(*found[0], "class") == "panel");
  return *found[0];
}

std::vector<std::string> texts(const XmlNode& root) {
  std::vector<const XmlNode*> nodes;
  collect(
      root, [](const XmlNode& n) { return n.name == "text"; }, nodes);
  std::vector<std::string> out;
  for (const XmlNode* n : nodes) out.push_back(n->text);
  return out;
}

bool hasText(const XmlNode& root, const std::string& t) {
  const std::vector<std::string> all = texts(root);
  return std::find(all.begin(), all.end(), t) != all.end();
}

double number(const std::string& s) {
  std::istringstream in(s);
  in.imbue(std::locale::classic());
  double v = 0;
  in >> v;
  REQUIRE_MESSAGE(in, "not a number: " << s);
  return v;
}

std::vector<Eigen::Vector2d> polylinePoints(const XmlNode& n) {
  std::istringstream in(attr(n, "points"));
  std::vector<Eigen::Vector2d> out;
  double u = 0, v = 0;
  char comma = 0;
  while (in >> u >> comma >> v) {
    REQUIRE(comma == ',');
    out.emplace_back(u, v);
  }
  return out;
}

// A panel's map from user units back to metres.
struct PanelMap {
  double scale, ox, oy;
  explicit PanelMap(const XmlNode& p)
      : scale(number(attr(p, "data-scale"))),
        ox(number(attr(p, "data-origin-x"))),
        oy(number(attr(p, "data-origin-y"))) {}
  Eigen::Vector2d metres(const Eigen::Vector2d& uv) const {
    return {(uv.x() - ox) / scale, (oy - uv.y()) / scale};
  }
  double tolerance() const { return 0.006 / scale + 1e-5; }  // 2 decimals of user units
};

std::size_t countOf(const std::string& s, char c) {
  return static_cast<std::size_t>(std::count(s.begin(), s.end(), c));
}

// The number of "M" segments in the panel's loop-closure path (0 if none is drawn).
std::size_t loopSegments(const XmlNode& p) {
  const auto paths = byClass(p, "loop-closures");
  REQUIRE(paths.size() <= 1);
  return paths.empty() ? 0 : countOf(attr(*paths[0], "d"), 'M');
}

// ---- Datasets ----------------------------------------------------------------------------------

// Coordinates (a, b) of the positions of the poses in id order: a = x, b = y or z.
std::vector<Eigen::Vector2d> poseCoordinates(const ModelEstimate& e, int n, int b) {
  std::vector<Eigen::Vector2d> out;
  for (int i = 0; i < n; ++i) out.emplace_back(e.at(pose(i))[0], e.at(pose(i))[b]);
  return out;
}

// n 2D poses on a random walk, odometry between consecutive ones, the given loop closures.
struct Graph {
  ModelDataset dataset;
  ModelEstimate estimate;
  ModelEstimate truth;
};

void addBetween(ModelDataset& d, int i, int j) {
  if (d.dimension == 2) {
    d.factors.push_back(factor(FactorKind::BetweenSE2, pose(i), pose(j), Eigen::Vector3d::Zero(),
                               Eigen::Matrix3d::Identity()));
  } else {
    Vector7d z = Vector7d::Zero();
    z[6] = 1;
    d.factors.push_back(factor(FactorKind::BetweenSE3, pose(i), pose(j), z,
                               Eigen::Matrix<double, 6, 6>::Identity()));
  }
}

Eigen::VectorXd poseValue(int dimension, const Eigen::Vector3d& p) {
  if (dimension == 2) return Eigen::Vector3d(p.x(), p.y(), 0.3);
  Vector7d v;
  v << p.x(), p.y(), p.z(), 0, 0, 0, 1;
  return v;
}

Graph walk(int dimension, int n, const std::vector<std::pair<int, int>>& loops, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> step(0.0, 3.0);
  Graph g;
  g.dataset.name = "walk";
  g.dataset.dimension = dimension;
  Eigen::Vector3d p(100.0, -40.0, dimension == 3 ? 5.0 : 0.0);  // away from the origin
  for (int i = 0; i < n; ++i) {
    g.estimate[pose(i)] = poseValue(dimension, p);
    Eigen::Vector3d off(step(rng), step(rng), dimension == 3 ? 0.3 * step(rng) : 0.0);
    g.truth[pose(i)] = poseValue(dimension, p + 0.1 * off);
    p += off;
    if (i > 0) addBetween(g.dataset, i - 1, i);
  }
  for (const auto& [i, j] : loops) addBetween(g.dataset, i, j);
  return g;
}

void addLandmarks(Graph& g, int count) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-30.0, 30.0);
  const int dim = g.dataset.dimension;
  for (int k = 0; k < count; ++k) {
    const Eigen::Vector3d l(100 + u(rng), -40 + u(rng), dim == 3 ? u(rng) : 0.0);
    g.estimate[landmark(k)] = l.head(dim);
    g.truth[landmark(k)] = (l + Eigen::Vector3d::Constant(0.5)).head(dim);
    const FactorKind kind = dim == 2 ? FactorKind::PointXY2 : FactorKind::PointXYZ3;
    g.dataset.factors.push_back(factor(kind, pose(k), landmark(k), Eigen::VectorXd::Zero(dim),
                                       Eigen::MatrixXd::Identity(dim, dim)));
  }
}

MapPlotInput input(const Graph& g, bool with_truth, std::string title = "map") {
  MapPlotInput in;
  in.dataset = &g.dataset;
  in.estimate = &g.estimate;
  in.truth = with_truth ? &g.truth : nullptr;
  in.title = std::move(title);
  return in;
}

// The trajectory polyline of a panel maps back to `expected` (metres, id order) and lies in the
// panel's frame; the leftmost point is the pose with the least a, the topmost the greatest b.
void checkTrajectory(const XmlNode& p, const std::string& cls,
                     const std::vector<Eigen::Vector2d>& expected) {
  const auto lines = byClass(p, cls);
  REQUIRE(lines.size() == 1);
  const std::vector<Eigen::Vector2d> uv = polylinePoints(*lines[0]);
  REQUIRE(uv.size() == expected.size());
  const PanelMap map(p);
  for (std::size_t i = 0; i < uv.size(); ++i) {
    CHECK((map.metres(uv[i]) - expected[i]).cwiseAbs().maxCoeff() <= map.tolerance());
  }
  const auto frame = byClass(p, "frame");
  REQUIRE(frame.size() == 1);
  const double left = number(attr(*frame[0], "x")), top = number(attr(*frame[0], "y"));
  const double right = left + number(attr(*frame[0], "width"));
  const double bottom = top + number(attr(*frame[0], "height"));
  for (const Eigen::Vector2d& q : uv) {
    CHECK(q.x() >= left);
    CHECK(q.x() <= right);
    CHECK(q.y() >= top);
    CHECK(q.y() <= bottom);
  }
  const auto lessA = [](const Eigen::Vector2d& x, const Eigen::Vector2d& y) {
    return x.x() < y.x();
  };
  const auto lessB = [](const Eigen::Vector2d& x, const Eigen::Vector2d& y) {
    return x.y() < y.y();
  };
  CHECK(std::min_element(uv.begin(), uv.end(), lessA) - uv.begin() ==
        std::min_element(expected.begin(), expected.end(), lessA) - expected.begin());
  CHECK(std::min_element(uv.begin(), uv.end(), lessB) - uv.begin() ==
        std::max_element(expected.begin(), expected.end(), lessB) - expected.begin());
}

bool isNiceStep(double step) {
  const double mantissa = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
  return std::abs(mantissa - 1) < 1e-6 || std::abs(mantissa - 2) < 1e-6 ||
         std::abs(mantissa - 5) < 1e-6;
}

// The horizontal tick labels are metres at a 1, 2 or 5 x 10^k step, placed where the panel's
// map puts those metres.
void checkTicks(const XmlNode& p) {
  const auto labels = byClass(p, "tick-label-a");
  REQUIRE(labels.size() >= 2);
  const PanelMap map(p);
  const double step = number(labels[1]->text) - number(labels[0]->text);
  CHECK(isNiceStep(step));
  for (std::size_t i = 0; i < labels.size(); ++i) {
    const double value = number(labels[i]->text);
    if (i > 0) CHECK(value - number(labels[i - 1]->text) == doctest::Approx(step));
    CHECK(std::abs(map.metres({number(attr(*labels[i], "x")), 0}).x() - value) <= map.tolerance());
  }
  CHECK(byClass(p, "tick-label-b").size() >= 1);
}

void checkScaleBar(const XmlNode& p) {
  const auto bars = byClass(p, "scale-bar");
  REQUIRE(bars.size() == 1);
  const std::vector<std::string> t = texts(*bars[0]);
  REQUIRE(t.size() == 1);
  REQUIRE(t[0].size() > 2);
  CHECK(t[0].substr(t[0].size() - 2) == " m");
  CHECK(isNiceStep(number(t[0])));
}

bool hasNonFinite(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s.find("nan") != std::string::npos || s.find("inf") != std::string::npos;
}

}  // namespace

TEST_CASE("2D pose graph: one panel, the trajectory in metres, loop closures, axes") {
  // Loop closures: (20, 3), (29, 0), (15, 5); (8, 7) is a reversed odometry, not a loop.
  Graph g = walk(2, 30, {{20, 3}, {29, 0}, {15, 5}, {8, 7}});
  g.dataset.factors.push_back(factor(FactorKind::PriorSE2, pose(0), pose(0),
                                     Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()));
  const std::string svg = renderMapSvg(input(g, false));
  const XmlNode root = readSvg(svg);
  CHECK(byClass(root, "panel").size() == 1);
  const XmlNode& p = panel(root, "panel-xy");
  checkTrajectory(p, "trajectory-estimate", poseCoordinates(g.estimate, 30, 1));
  CHECK(byClass(root, "trajectory-truth").empty());
  CHECK(byClass(root, "landmark-estimate").empty());
  CHECK(loopSegments(p) == 3);
  CHECK(hasText(root, "loop closures (3)"));
  CHECK(hasText(p, "x [m]"));
  CHECK(hasText(p, "y [m]"));
  CHECK(hasText(root, "map"));
  checkTicks(p);
  checkScaleBar(p);
  CHECK_FALSE(hasNonFinite(svg));
}

TEST_CASE("2D graph with landmarks and truth: a marker per landmark, the truth beside") {
  Graph g = walk(2, 20, {{19, 2}});
  addLandmarks(g, 7);
  const XmlNode root = readSvg(renderMapSvg(input(g, true)));
  const XmlNode& p = panel(root, "panel-xy");
  checkTrajectory(p, "trajectory-estimate", poseCoordinates(g.estimate, 20, 1));
  checkTrajectory(p, "trajectory-truth", poseCoordinates(g.truth, 20, 1));
  CHECK(byClass(p, "landmark-estimate").size() == 7);
  CHECK(byClass(p, "landmark-truth").size() == 7);
  CHECK(loopSegments(p) == 1);  // the landmark observations are no loop closures
  for (const char* name : {"estimate", "ground truth", "landmarks (estimate)",
                           "landmarks (ground truth)", "loop closures (1)"}) {
    CHECK_MESSAGE(hasText(root, name), name);
  }
  // A landmark circle is where its metres are.
  const PanelMap map(p);
  const XmlNode& c = *byClass(p, "landmark-estimate")[0];
  const Eigen::Vector2d at = map.metres({number(attr(c, "cx")), number(attr(c, "cy"))});
  CHECK((at - Eigen::Vector2d(g.estimate.at(landmark(0)).head<2>())).cwiseAbs().maxCoeff() <=
        map.tolerance());
}

TEST_CASE("3D graph with landmarks and truth: a top and a side view, each complete") {
  Graph g = walk(3, 40, {{39, 1}, {25, 10}});
  addLandmarks(g, 5);
  const std::string svg = renderMapSvg(input(g, true));
  const XmlNode root = readSvg(svg);
  CHECK(byClass(root, "panel").size() == 2);
  const XmlNode& top = panel(root, "panel-xy");
  const XmlNode& side = panel(root, "panel-xz");
  checkTrajectory(top, "trajectory-estimate", poseCoordinates(g.estimate, 40, 1));
  checkTrajectory(top, "trajectory-truth", poseCoordinates(g.truth, 40, 1));
  checkTrajectory(side, "trajectory-estimate", poseCoordinates(g.estimate, 40, 2));
  checkTrajectory(side, "trajectory-truth", poseCoordinates(g.truth, 40, 2));
  for (const XmlNode* p : {&top, &side}) {
    CHECK(byClass(*p, "landmark-estimate").size() == 5);
    CHECK(byClass(*p, "landmark-truth").size() == 5);
    CHECK(loopSegments(*p) == 2);
    CHECK(hasText(*p, "x [m]"));
    checkTicks(*p);
    checkScaleBar(*p);
  }
  CHECK(hasText(top, "y [m]"));
  CHECK(hasText(side, "z [m]"));
  CHECK_FALSE(hasText(side, "y [m]"));
  // One metre is as long in both panels and on both axes (one scale attribute per panel).
  CHECK(PanelMap(top).scale == PanelMap(side).scale);
  // The side view lies right of the top view.
  CHECK(number(attr(*byClass(side, "frame")[0], "x")) >
        number(attr(*byClass(top, "frame")[0], "x")) +
            number(attr(*byClass(top, "frame")[0], "width")));
  CHECK_FALSE(hasNonFinite(svg));
}

TEST_CASE("loop closures beyond the cap are left out and the legend says so") {
  std::vector<std::pair<int, int>> loops(kMaxLoopClosuresDrawn + 5, {9, 0});
  const Graph g = walk(2, 10, loops);
  const XmlNode root = readSvg(renderMapSvg(input(g, false)));
  CHECK(loopSegments(panel(root, "panel-xy")) == kMaxLoopClosuresDrawn);
  CHECK(hasText(root, "loop closures (first 20000 of 20005 drawn)"));
}

TEST_CASE("a title with markup characters is escaped") {
  const Graph g = walk(2, 5, {});
  const std::string title = "a <b> & \"c\" 'd'";
  const std::string svg = renderMapSvg(input(g, false, title));
  CHECK(svg.find(title) == std::string::npos);
  const XmlNode root = readSvg(svg);
  const auto titles = byClass(root, "title");
  REQUIRE(titles.size() == 1);
  CHECK(titles[0]->text == title);
}

TEST_CASE("an empty estimate, a single pose or a non-finite value: no NaN or inf") {
  for (const int dim : {2, 3}) {
    const std::size_t panels = dim == 3 ? 2 : 1;
    Graph g = walk(dim, 1, {});
    const std::string one = renderMapSvg(input(g, true));
    readSvg(one);
    CHECK_FALSE(hasNonFinite(one));
    CHECK(byClass(readSvg(one), "trajectory-estimate").size() == panels);

    g.estimate[pose(1)] = poseValue(dim, Eigen::Vector3d(std::nan(""), 1.0, 1.0));
    const std::string with_nan = renderMapSvg(input(g, false));
    CHECK_FALSE(hasNonFinite(with_nan));
    CHECK(polylinePoints(*byClass(readSvg(with_nan), "trajectory-estimate")[0]).size() == 1);

    const ModelEstimate empty;
    MapPlotInput in = input(g, false);
    in.estimate = &empty;
    const std::string none = renderMapSvg(in);
    CHECK_FALSE(hasNonFinite(none));
    CHECK(byClass(readSvg(none), "panel").size() == panels);
  }
}

TEST_CASE("a diverged pose is left out; a cluster at one point still gets distinct ticks") {
  Graph g = walk(2, 3, {});
  g.estimate[pose(3)] = poseValue(2, Eigen::Vector3d(1e200, -1e200, 0.0));
  const XmlNode far = readSvg(renderMapSvg(input(g, false)));
  CHECK(polylinePoints(*byClass(far, "trajectory-estimate")[0]).size() == 3);

  Graph tight = walk(2, 2, {});
  tight.estimate[pose(0)] = poseValue(2, Eigen::Vector3d(5.0, 5.0, 0.0));
  tight.estimate[pose(1)] = poseValue(2, Eigen::Vector3d(5.0 + 1e-9, 5.0, 0.0));
  const std::string svg = renderMapSvg(input(tight, false));
  CHECK_FALSE(hasNonFinite(svg));
  const XmlNode root = readSvg(svg);
  for (const char* cls : {"tick-label-a", "tick-label-b"}) {
    std::vector<std::string> labels;
    for (const XmlNode* n : byClass(root, cls)) labels.push_back(n->text);
    CHECK(labels.size() >= 2);
    CHECK(std::unique(labels.begin(), labels.end()) == labels.end());
  }
}

TEST_CASE("writeMapSvg writes the document and reports an unwritable path") {
  const Graph g = walk(2, 5, {});
  const std::string path = "test_map_plot_output.svg";
  writeMapSvg(path, input(g, false));
  std::ifstream in(path, std::ios::binary);
  std::ostringstream content;
  content << in.rdbuf();
  CHECK(content.str() == renderMapSvg(input(g, false)));
  std::remove(path.c_str());
  CHECK_THROWS_AS(writeMapSvg("/nonexistent-directory/map.svg", input(g, false)),
                  std::runtime_error);
  MapPlotInput missing;
  CHECK_THROWS_AS(renderMapSvg(missing), std::invalid_argument);
}
