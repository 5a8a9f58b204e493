#include "host_sim/cli_args.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <system_error>
#include <utility>

namespace lslam::sim {

std::optional<std::int64_t> parseIntegerArg(std::string_view token, std::int64_t min,
                                            std::int64_t max) {
  if (token.empty()) return std::nullopt;
  std::int64_t value = 0;
  const char* end = token.data() + token.size();
  const auto res = std::from_chars(token.data(), end, value, 10);
  if (res.ec != std::errc() || res.ptr != end) return std::nullopt;
  if (value < min || value > max) return std::nullopt;
  return value;
}

std::optional<double> parseRealArg(std::string_view token, double min, double max) {
  if (token.empty()) return std::nullopt;
  double value = 0.0;
  const char* end = token.data() + token.size();
  const auto res = std::from_chars(token.data(), end, value, std::chars_format::general);
  if (res.ec != std::errc() || res.ptr != end) return std::nullopt;
  if (!std::isfinite(value) || value < min || value > max) return std::nullopt;
  return value;
}

std::string jsonString(std::string_view s) {
  static const char* const kHex = "0123456789abcdef";
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\b':
        out += "\\b";
        break;
      case '\f':
        out += "\\f";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20 || c == 0x7f) {
          out += "\\u00";
          out += kHex[c >> 4];
          out += kHex[c & 0xf];
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}

namespace {

using Error = std::optional<std::string>;

Error invalidValue(const std::string& option, const std::string& value, const char* expected) {
  return option + ": invalid value " + jsonString(value) + " (expected " + expected + ")";
}

// One option of a command: its name, whether it takes a value, and what to do with it (nullopt, or
// the message of an invalid value). A flag's action gets an empty value.
struct Option {
  std::string name;
  bool takes_value;
  std::function<Error(const std::string& option, const std::string& value)> apply;
};

Option flag(const char* name, bool& target, bool value) {
  return {name, false, [&target, value](const std::string&, const std::string&) -> Error {
            target = value;
            return std::nullopt;
          }};
}

Option path(const char* name, std::string& target) {
  return {name, true, [&target](const std::string& option, const std::string& value) -> Error {
            if (value.empty()) return invalidValue(option, value, "a file path");
            target = value;
            return std::nullopt;
          }};
}

template <typename Int>
Option integer(const char* name, Int& target, std::int64_t min, const char* expected) {
  return {name, true,
          [&target, min, expected](const std::string& option, const std::string& value) -> Error {
            const auto n = parseIntegerArg(value, min, std::numeric_limits<Int>::max());
            if (!n) return invalidValue(option, value, expected);
            target = static_cast<Int>(*n);
            return std::nullopt;
          }};
}

// A finite number in [min, max] (excluding min itself if `open_min`).
Option real(const char* name, double& target, double min = 0.0,
            double max = std::numeric_limits<double>::max(),
            const char* expected = "a finite number >= 0", bool open_min = false) {
  return {name, true,
          [&target, min, max, expected, open_min](const std::string& option,
                                                  const std::string& value) -> Error {
            const auto x = parseRealArg(value, min, max);
            if (!x || (open_min && *x == min)) return invalidValue(option, value, expected);
            target = *x;
            return std::nullopt;
          }};
}

Option positiveReal(const char* name, double& target) {
  return real(name, target, 0.0, std::numeric_limits<double>::max(), "a finite number > 0", true);
}

Option fraction(const char* name, double& target) {
  return real(name, target, 0.0, 1.0, "a number in [0, 1]");
}

// The arguments of one command: options from `options`, each at most once, and exactly one
// positional argument (named `positional_name` in messages) into `positional`.
Error parseCommand(const std::vector<std::string>& argv, const std::vector<Option>& options,
                   const char* positional_name, std::string& positional) {
  std::vector<bool> seen(options.size(), false);
  bool have_positional = false;
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& a = argv[i];
    if (a.empty() || a[0] != '-') {
      if (have_positional) {
        return "unexpected argument " + jsonString(a) + " (" + positional_name + " is " +
               jsonString(positional) + ")";
      }
      if (a.empty())
        return std::string("invalid ") + positional_name + " \"\" (expected a file path)";
      positional = a;
      have_positional = true;
      continue;
    }
    const auto option =
        std::find_if(options.begin(), options.end(), [&](const Option& o) { return o.name == a; });
    if (option == options.end()) return "unknown option " + jsonString(a);
    const auto index = static_cast<std::size_t>(option - options.begin());
    if (seen[index]) return a + " given twice";
    seen[index] = true;
    if (!option->takes_value) {
      option->apply(a, std::string());
      continue;
    }
    if (i + 1 >= argv.size()) return a + " needs a value";
    // A value never starts with "--": that is the next option, and this one's value is missing.
    if (argv[i + 1].rfind("--", 0) == 0) {
      return a + " needs a value (found the option " + jsonString(argv[i + 1]) + ")";
    }
    if (Error error = option->apply(a, argv[++i])) return error;
  }
  if (!have_positional) return std::string("missing ") + positional_name;
  return std::nullopt;
}

}  // namespace

std::optional<std::string> parseRunArgs(const std::vector<std::string>& argv, RunArgs& args) {
  SolverOptions& so = args.solver;
  const std::vector<Option> options = {
      flag("--json", args.json, true),
      flag("--reorder-top", so.reorder_affected_top, true),
      flag("--no-row-updates", so.row_updates, false),
      flag("--order-in-one-update", so.prepare_ordering_ahead, false),
      {"--order", true,
       [&](const std::string& option, const std::string& value) -> Error {
         if (value != "online" && value != "file") {
           return invalidValue(option, value, "online or file");
         }
         args.order = value == "online" ? StepOrder::Online : StepOrder::File;
         return std::nullopt;
       }},
      integer("--solve-every", args.solve_every, 1, "an integer >= 1"),
      integer("--factor-blocks", args.factor_blocks, 1, "an integer in 1..2147483647"),
      integer("--max-poses", args.max_poses, 2, "an integer in 2..2147483647"),
      flag("--no-batch", args.batch, false),
      path("--csv", args.csv),
      path("--out", args.out),
      path("--report", args.report),
      path("--truth", args.truth),
      path("--plot", args.plot),
      integer("--prepare-min-products", so.prepare_ordering_min_products, 0, "an integer >= 0"),
      integer("--relinearize-defer", so.relinearize_defer_products, 0, "an integer >= 0"),
      integer("--spread-reorder", so.spread_reorder_products, 0, "an integer >= 0"),
      integer("--relinearize-defer-updates", so.relinearize_defer_updates, 0,
              "an integer in 0..2147483647"),
      real("--relinearize-threshold", so.relinearize_threshold),
      real("--relinearize-landmark-threshold", so.relinearize_threshold_of_kind[1]),
      real("--relinearize-urgent", so.relinearize_urgent_threshold),
      real("--relinearize-partial", so.relinearize_partial_threshold),
      real("--backsub-tolerance", so.backsubstitution_tolerance),
      real("--reorder-growth", so.reorder_growth),
      real("--reorder-excess", so.reorder_excess_ratio),
      real("--reorder-relinearized", so.reorder_relinearized_share),
      real("--reorder-refresh", so.reorder_refresh_growth),
      real("--relinearize-full-cost", so.relinearize_full_cost_ratio),
      integer("--relinearize-skip", so.relinearize_skip, 0, "an integer in 0..2147483647"),
      integer("--urgent-iterations", so.urgent_iterations, 0, "an integer in 0..2147483647"),
      integer("--reorder-path", so.reorder_path_columns, 0, "an integer in 0..2147483647"),
      integer("--reorder-burst", so.reorder_burst_loop_closures, 0, "an integer in 0..2147483647"),
  };
  if (auto error = parseCommand(argv, options, "DATASET", args.dataset)) return error;
  if (args.max_poses > 0 && args.order == StepOrder::File) {
    return std::string("--max-poses runs in online order (not with --order file)");
  }
  return std::nullopt;
}

std::optional<std::string> parseGenerateArgs(const std::vector<std::string>& argv,
                                             GenerateArgs& args) {
  const std::vector<Option> options = {
      integer("--poses", args.options.poses, 1, "an integer >= 1"),
      integer("--seed", args.options.seed, 0, "an integer in 0..4294967295"),
  };
  return parseCommand(argv, options, "OUT.g2o", args.out);
}

namespace {

// The options of `simulate`, writing into `o`.
std::vector<Option> simulateOptions(WorldOptions& o) {
  return {
      integer("--steps", o.steps, 2, "an integer >= 2"),
      integer("--seed", o.seed, 0, "an integer in 0..4294967295"),
      positiveReal("--sigma-translation", o.sigma_translation),
      positiveReal("--sigma-rotation", o.sigma_rotation),
      positiveReal("--sigma-landmark", o.sigma_landmark),
      positiveReal("--sigma-range", o.sigma_range),
      positiveReal("--sigma-bearing", o.sigma_bearing),
      fraction("--loop-probability", o.loop_probability),
      integer("--max-loops", o.max_loops_per_pose, 0, "an integer >= 0"),
      real("--loop-radius", o.loop_radius),
      integer("--loop-separation", o.min_loop_separation, 2, "an integer >= 2"),
      fraction("--outlier-rate", o.outlier_rate),
      integer("--landmarks", o.landmarks, 0, "an integer >= 0"),
      real("--sensor-range", o.sensor_range),
      integer("--max-observations", o.max_observations_per_pose, 0, "an integer >= 0"),
      {"--landmark-measurement", true,
       [&o](const std::string& option, const std::string& value) -> Error {
         if (value != "position" && value != "range-bearing") {
           return invalidValue(option, value, "position or range-bearing");
         }
         o.landmark_measurement = value == "position" ? LandmarkMeasurement::Position
                                                      : LandmarkMeasurement::RangeBearing;
         return std::nullopt;
       }},
      integer("--grid-size", o.grid_size, 2, "an integer >= 2"),
      fraction("--turn-probability", o.turn_probability),
      positiveReal("--radius", o.radius),
      integer("--floors", o.floors, 1, "an integer >= 1"),
  };
}

}  // namespace

std::optional<std::string> parseSimulateArgs(const std::vector<std::string>& argv,
                                             SimulateArgs& args) {
  if (argv.empty() || argv[0].empty() || argv[0][0] == '-') {
    return std::string("missing WORLD (grid2d, sphere3d, garage3d or points3d)");
  }
  const auto kind = parseWorldKind(argv[0]);
  if (!kind) {
    return "unknown world " + jsonString(argv[0]) +
           " (expected grid2d, sphere3d, garage3d or points3d)";
  }
  args.world = *kind;
  args.options = defaultWorldOptions(*kind);
  const std::vector<Option> options = simulateOptions(args.options);
  const std::vector<std::string> rest(argv.begin() + 1, argv.end());
  return parseCommand(rest, options, "OUT.g2o", args.out);
}

const char* simulateHelp() {
  return "lslam-sim simulate WORLD OUT.g2o [options]\n"
         "  Writes a noisy g2o dataset to OUT.g2o and its ground truth (the true poses and "
         "landmarks "
         "as\n"
         "  vertices) to OUT.truth.g2o. Deterministic for a seed.\n"
         "worlds (default steps):\n"
         "  grid2d    Manhattan grid, point landmarks seen within a sensor range (1000)\n"
         "  sphere3d  rings of latitude on a sphere, a loop closure one ring back per pose (2500)\n"
         "  garage3d  rectangular floors joined by ramps, driven up and down again (1600)\n"
         "  points3d  laps of a wavy circle observing 3D point landmarks within range (1000)\n"
         "options (defaults in brackets; [world] where a world differs):\n"
         "  --steps N                 poses (>= 2)\n"
         "  --seed S                  random seed [1]\n"
         "  --sigma-translation M     odometry and loop-closure noise per axis, m [0.05]\n"
         "  --sigma-rotation R        rotation noise, rad (3D: per axis) [0.01]\n"
         "  --sigma-landmark M        landmark position noise per axis, m [0.05]\n"
         "  --sigma-range M           range noise, m [0.05]\n"
         "  --sigma-bearing R         bearing noise, rad [0.01]\n"
         "  --loop-probability P      chance a pose with candidates closes loops\n"
         "                            [0.5; sphere3d 1; garage3d 0.8; points3d 0.3]\n"
         "  --max-loops N             loop closures per pose at most [2; sphere3d 1]\n"
         "  --loop-radius M           loop-closure distance, m (grid2d, garage3d); wrong loop\n"
         "                            closures join poses over 2 M + 1 m apart (all) [1]\n"
         "  --loop-separation N       loop closures at least N poses back (grid2d, garage3d;\n"
         "                            wrong ones: all) [10]\n"
         "  --outlier-rate P          chance a pose gets one wrong loop closure [0]\n"
         "  --landmarks N             landmarks scattered (grid2d, points3d) [200; points3d 60]\n"
         "  --sensor-range M          landmarks observed within, m (grid2d, points3d)\n"
         "                            [1.5; points3d 4]\n"
         "  --max-observations N      nearest landmarks observed per pose at most (grid2d,\n"
         "                            points3d) [3]\n"
         "  --landmark-measurement K  grid2d: position (EDGE_SE2_XY) or range-bearing\n"
         "                            (EDGE_SE2_RANGE_BEARING) [position]\n"
         "  --grid-size N             grid2d: intersections per side [10]\n"
         "  --turn-probability P      grid2d: chance to turn at an intersection [0.3]\n"
         "  --radius M                sphere3d, points3d: radius, m [10]\n"
         "  --floors N                garage3d: floors [4]\n";
}

std::vector<std::string> simulateOptionNames() {
  WorldOptions unused;
  std::vector<std::string> names;
  for (const Option& o : simulateOptions(unused)) names.push_back(o.name);
  return names;
}

}  // namespace lslam::sim
