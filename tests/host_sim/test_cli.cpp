// Tests of lslam-sim's command lines (host_sim/cli_args.h): every usage error names the argument at
// fault, and valid lines fill in every option. (tests/host_sim/lslam_sim_usage.cmake checks that
// the executable prints these messages and exits with status 2.)
#include <doctest/doctest.h>

#include <optional>
#include <string>
#include <vector>

#include "host_sim/cli_args.h"

using lslam::sim::GenerateArgs;
using lslam::sim::parseGenerateArgs;
using lslam::sim::parseRunArgs;
using lslam::sim::RunArgs;
using lslam::sim::StepOrder;

namespace {

using Argv = std::vector<std::string>;

// The usage error of `lslam-sim run ARGV...` ("" when the line is valid).
std::string runError(const Argv& argv) {
  RunArgs args;
  return parseRunArgs(argv, args).value_or("");
}

std::string generateError(const Argv& argv) {
  GenerateArgs args;
  return parseGenerateArgs(argv, args).value_or("");
}

}  // namespace

TEST_CASE("run: an unknown option is named as one, wherever it stands") {
  CHECK(runError({"--bogus", "data.g2o"}) == "unknown option \"--bogus\"");
  CHECK(runError({"data.g2o", "--order", "file", "--max-poses", "10"}) ==
        "--max-poses runs in online order (not with --order file)");
  CHECK(runError({"data.g2o", "--bogus"}) == "unknown option \"--bogus\"");
  CHECK(runError({"--bogus"}) == "unknown option \"--bogus\"");
  CHECK(runError({"data.g2o", "--json", "-j"}) == "unknown option \"-j\"");
  CHECK(runError({"-", "data.g2o"}) == "unknown option \"-\"");
  // A known option's name with a value attached is no option either.
  CHECK(runError({"data.g2o", "--order=file"}) == "unknown option \"--order=file\"");
}

TEST_CASE("run: DATASET exactly once, and not empty") {
  CHECK(runError({}) == "missing DATASET");
  CHECK(runError({"--json"}) == "missing DATASET");
  CHECK(runError({"--out", "estimate.g2o"}) == "missing DATASET");
  CHECK(runError({"a.g2o", "b.g2o"}) == "unexpected argument \"b.g2o\" (DATASET is \"a.g2o\")");
  CHECK(runError({"a.g2o", "--json", "a.g2o"}) ==
        "unexpected argument \"a.g2o\" (DATASET is \"a.g2o\")");
  CHECK(runError({""}) == "invalid DATASET \"\" (expected a file path)");
}

TEST_CASE("run: an option without its value, at the end of the line or before another option") {
  for (const char* option : {"--order",
                             "--solve-every",
                             "--csv",
                             "--out",
                             "--report",
                             "--prepare-min-products",
                             "--relinearize-threshold",
                             "--relinearize-landmark-threshold",
                             "--relinearize-urgent",
                             "--relinearize-partial",
                             "--backsub-tolerance",
                             "--reorder-growth",
                             "--reorder-excess",
                             "--reorder-relinearized",
                             "--reorder-refresh",
                             "--relinearize-full-cost",
                             "--relinearize-skip",
                             "--reorder-path",
                             "--reorder-burst",
                             "--factor-blocks",
                             "--relinearize-defer",
                             "--relinearize-defer-updates"}) {
    CAPTURE(option);
    CHECK(runError({"data.g2o", option}) == std::string(option) + " needs a value");
    CHECK(runError({option, "--json", "data.g2o"}) ==
          std::string(option) + " needs a value (found the option \"--json\")");
  }
  // A value may start with a single '-' (then it is checked as a value).
  CHECK(runError({"data.g2o", "--relinearize-threshold", "-1"}) ==
        "--relinearize-threshold: invalid value \"-1\" (expected a finite number >= 0)");
}

TEST_CASE("run: invalid values are named with what was expected") {
  CHECK(runError({"data.g2o", "--order", "random"}) ==
        "--order: invalid value \"random\" (expected online or file)");
  CHECK(runError({"data.g2o", "--solve-every", "0"}) ==
        "--solve-every: invalid value \"0\" (expected an integer >= 1)");
  CHECK(runError({"data.g2o", "--reorder-path", "2147483648"}) ==
        "--reorder-path: invalid value \"2147483648\" (expected an integer in 0..2147483647)");
  CHECK(runError({"data.g2o", "--reorder-growth", "nan"}) ==
        "--reorder-growth: invalid value \"nan\" (expected a finite number >= 0)");
  CHECK(runError({"data.g2o", "--out", ""}) == "--out: invalid value \"\" (expected a file path)");
}

TEST_CASE("run: --factor-blocks takes a positive block count, once") {
  RunArgs args;
  REQUIRE(parseRunArgs({"data.g2o", "--factor-blocks", "250000"}, args) == std::nullopt);
  CHECK(args.factor_blocks == 250000);
  RunArgs defaults;
  REQUIRE(parseRunArgs({"data.g2o"}, defaults) == std::nullopt);
  CHECK(defaults.factor_blocks == 0);  // sized from the dataset
  for (const char* value : {"0", "-5", "1.5", "1e6", "2147483648", "abc", ""}) {
    CAPTURE(value);
    CHECK(runError({"data.g2o", "--factor-blocks", value}) ==
          std::string("--factor-blocks: invalid value \"") + value +
              "\" (expected an integer in 1..2147483647)");
  }
  CHECK(runError({"data.g2o", "--factor-blocks", "1", "--factor-blocks", "2"}) ==
        "--factor-blocks given twice");
}

TEST_CASE("run: an option given twice is an error, not the last one winning") {
  CHECK(runError({"data.g2o", "--order", "file", "--order", "online"}) == "--order given twice");
  CHECK(runError({"data.g2o", "--json", "--json"}) == "--json given twice");
}

TEST_CASE("run: a valid line sets every option, DATASET anywhere among them") {
  RunArgs args;
  // clang-format off
  const Argv argv = {"--order", "file", "--solve-every", "3", "--json", "--csv", "steps.csv",
                     "data.g2o", "--out", "estimate.g2o", "--report", "report.json",
                     "--relinearize-threshold", "0.5", "--relinearize-urgent", "0.6",
                     "--relinearize-partial", "0.7", "--backsub-tolerance", "1e-4",
                     "--reorder-growth", "2", "--reorder-excess", "3",
                     "--reorder-relinearized", "0.25", "--reorder-refresh", "4",
                     "--relinearize-full-cost", "5", "--relinearize-skip", "6",
                     "--reorder-path", "7", "--reorder-burst", "8", "--prepare-min-products", "9",
                     "--relinearize-defer", "10", "--relinearize-defer-updates", "11",
                     "--relinearize-landmark-threshold", "0.02",
                     "--reorder-top", "--no-row-updates", "--order-in-one-update"};
  // clang-format on
  REQUIRE(parseRunArgs(argv, args) == std::nullopt);
  CHECK(args.dataset == "data.g2o");
  CHECK(args.order == StepOrder::File);
  CHECK(args.solve_every == 3);
  CHECK(args.json);
  CHECK(args.csv == "steps.csv");
  CHECK(args.out == "estimate.g2o");
  CHECK(args.report == "report.json");
  const lslam::SolverOptions& so = args.solver;
  CHECK(so.relinearize_threshold == 0.5);
  CHECK(so.relinearize_threshold_of_kind[0] == 0.0);
  CHECK(so.relinearize_threshold_of_kind[1] == 0.02);
  CHECK(so.relinearize_urgent_threshold == 0.6);
  CHECK(so.relinearize_partial_threshold == 0.7);
  CHECK(so.backsubstitution_tolerance == 1e-4);
  CHECK(so.reorder_growth == 2.0);
  CHECK(so.reorder_excess_ratio == 3.0);
  CHECK(so.reorder_relinearized_share == 0.25);
  CHECK(so.reorder_refresh_growth == 4.0);
  CHECK(so.relinearize_full_cost_ratio == 5.0);
  CHECK(so.relinearize_skip == 6);
  CHECK(so.reorder_path_columns == 7);
  CHECK(so.reorder_burst_loop_closures == 8);
  CHECK(so.prepare_ordering_min_products == 9);
  CHECK(so.relinearize_defer_products == 10);
  CHECK(so.relinearize_defer_updates == 11);
  CHECK(so.reorder_affected_top);
  CHECK_FALSE(so.row_updates);
  CHECK_FALSE(so.prepare_ordering_ahead);

  RunArgs defaults;
  REQUIRE(parseRunArgs({"data.g2o"}, defaults) == std::nullopt);
  CHECK(defaults.order == StepOrder::Online);
  CHECK(defaults.solve_every == 1);
  CHECK_FALSE(defaults.json);
  CHECK(defaults.out.empty());
}

TEST_CASE("generate: the same rules") {
  CHECK(generateError({"--bogus", "out.g2o"}) == "unknown option \"--bogus\"");
  CHECK(generateError({"out.g2o", "--bogus"}) == "unknown option \"--bogus\"");
  CHECK(generateError({}) == "missing OUT.g2o");
  CHECK(generateError({"--poses", "5"}) == "missing OUT.g2o");
  CHECK(generateError({"out.g2o", "--poses"}) == "--poses needs a value");
  CHECK(generateError({"out.g2o", "--seed"}) == "--seed needs a value");
  CHECK(generateError({"--poses", "--seed", "1", "out.g2o"}) ==
        "--poses needs a value (found the option \"--seed\")");
  CHECK(generateError({"a.g2o", "b.g2o"}) ==
        "unexpected argument \"b.g2o\" (OUT.g2o is \"a.g2o\")");
  CHECK(generateError({"out.g2o", "--poses", "0"}) ==
        "--poses: invalid value \"0\" (expected an integer >= 1)");
  CHECK(generateError({"out.g2o", "--seed", "4294967296"}) ==
        "--seed: invalid value \"4294967296\" (expected an integer in 0..4294967295)");
  CHECK(generateError({"out.g2o", "--seed", "1", "--seed", "2"}) == "--seed given twice");

  GenerateArgs args;
  REQUIRE(parseGenerateArgs({"--seed", "4294967295", "out.g2o", "--poses", "12"}, args) ==
          std::nullopt);
  CHECK(args.out == "out.g2o");
  CHECK(args.options.poses == 12);
  CHECK(args.options.seed == 4294967295u);
}

namespace {

std::string simulateError(const Argv& argv) {
  lslam::sim::SimulateArgs args;
  return lslam::sim::parseSimulateArgs(argv, args).value_or("");
}

}  // namespace

TEST_CASE("simulate: WORLD first, then the rules of the other commands") {
  CHECK(simulateError({}) == "missing WORLD (grid2d, sphere3d, garage3d or points3d)");
  CHECK(simulateError({"--steps", "5", "grid2d", "out.g2o"}) ==
        "missing WORLD (grid2d, sphere3d, garage3d or points3d)");
  CHECK(simulateError({"moon", "out.g2o"}) ==
        "unknown world \"moon\" (expected grid2d, sphere3d, garage3d or points3d)");
  CHECK(simulateError({"grid2d"}) == "missing OUT.g2o");
  CHECK(simulateError({"grid2d", "out.g2o", "--bogus"}) == "unknown option \"--bogus\"");
  CHECK(simulateError({"grid2d", "out.g2o", "--steps", "1"}) ==
        "--steps: invalid value \"1\" (expected an integer >= 2)");
  CHECK(simulateError({"grid2d", "out.g2o", "--sigma-rotation", "0"}) ==
        "--sigma-rotation: invalid value \"0\" (expected a finite number > 0)");
  CHECK(simulateError({"grid2d", "out.g2o", "--outlier-rate", "1.5"}) ==
        "--outlier-rate: invalid value \"1.5\" (expected a number in [0, 1])");
  CHECK(simulateError({"grid2d", "out.g2o", "--landmark-measurement", "sonar"}) ==
        "--landmark-measurement: invalid value \"sonar\" (expected position or range-bearing)");
  CHECK(simulateError({"grid2d", "out.g2o", "--floors", "2", "--floors", "3"}) ==
        "--floors given twice");

  // Options start from the world's defaults; the line overrides them.
  lslam::sim::SimulateArgs args;
  REQUIRE(lslam::sim::parseSimulateArgs({"sphere3d", "--seed", "9", "s.g2o", "--steps", "100"},
                                        args) == std::nullopt);
  CHECK(args.world == lslam::sim::WorldKind::Sphere3D);
  CHECK(args.out == "s.g2o");
  CHECK(args.options.steps == 100);
  CHECK(args.options.seed == 9u);
  const lslam::sim::WorldOptions sphere =
      lslam::sim::defaultWorldOptions(lslam::sim::WorldKind::Sphere3D);
  CHECK(args.options.loop_probability == sphere.loop_probability);
  REQUIRE(lslam::sim::parseSimulateArgs(
              {"grid2d", "g.g2o", "--landmark-measurement", "range-bearing", "--outlier-rate",
               "0.25", "--sigma-bearing", "0.02", "--grid-size", "7", "--landmarks", "0"},
              args) == std::nullopt);
  CHECK(args.options.landmark_measurement == lslam::sim::LandmarkMeasurement::RangeBearing);
  CHECK(args.options.outlier_rate == 0.25);
  CHECK(args.options.sigma_bearing == 0.02);
  CHECK(args.options.grid_size == 7);
  CHECK(args.options.landmarks == 0);
}

TEST_CASE("simulate --help documents every option simulate takes") {
  const std::string help = lslam::sim::simulateHelp();
  const std::vector<std::string> names = lslam::sim::simulateOptionNames();
  CHECK(names.size() >= 20);
  for (const std::string& name : names) {
    INFO(name);
    CHECK(help.find("  " + name + " ") != std::string::npos);
    // ... and simulate takes it (with a valid value for each).
    const std::string value = name == "--landmark-measurement" ? "range-bearing"
                              : name == "--steps" || name == "--floors" || name == "--grid-size" ||
                                      name == "--loop-separation"
                                  ? "3"
                                  : "1";
    CHECK(simulateError({"grid2d", "out.g2o", name, value}).empty());
  }
  for (const char* world : {"grid2d", "sphere3d", "garage3d", "points3d"}) {
    CHECK(help.find(std::string("  ") + world + " ") != std::string::npos);
  }
}
