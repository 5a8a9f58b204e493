#pragma once
// The command lines of the host tools (lslam-sim): the arguments of `run` and `generate`, strict
// parsing of option values, and JSON string literals. Host-only.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "host_sim/steps.h"
#include "host_sim/synthetic.h"
#include "host_sim/worlds.h"
#include "lslam/solver/solver_options.h"

namespace lslam::sim {

// A decimal integer in [min, max]: an optional '-' and digits only, the whole token (no blanks, no
// '+', no "0x", no trailing characters). nullopt otherwise (also when out of range).
std::optional<std::int64_t> parseIntegerArg(std::string_view token, std::int64_t min,
                                            std::int64_t max);

// A finite decimal number in [min, max] (std::from_chars' general format, e.g. "0.01", "1e-4"),
// the whole token. nullopt for anything else: "abc", "1x", "", "nan", "inf", "1e400", or a
// value outside the range.
std::optional<double> parseRealArg(std::string_view token, double min, double max);

// `s` as a JSON string literal in double quotes: '"' and '\' escaped, the control characters
// U+0000..U+001F as \b \f \n \r \t or \u00XX, and DEL as \u007f. Other bytes are copied as they
// are (a UTF-8 path stays UTF-8).
std::string jsonString(std::string_view s);

// `lslam-sim run DATASET [options]`.
struct RunArgs {
  std::string dataset;
  StepOrder order = StepOrder::Online;
  int solve_every = 1;
  Index factor_blocks = 0;  // the solver's block pool (0: sized from the dataset)
  Index max_poses = 0;      // > 0: a compact pose graph of at most this many poses
  bool batch = true;        // solve the batch reference (--no-batch: not)
  bool json = false;
  std::string csv, out, report;  // empty: not written
  std::string truth;             // ground truth to score against (empty: none)
  std::string plot;              // the map as SVG (empty: not drawn)
  SolverOptions solver;
};

// `lslam-sim generate OUT.g2o [--poses N] [--seed S]`.
struct GenerateArgs {
  std::string out;
  SyntheticOptions options;
};

// `lslam-sim simulate WORLD OUT.g2o [options]`: options start from defaultWorldOptions(world).
struct SimulateArgs {
  WorldKind world = WorldKind::Grid2D;
  std::string out;
  WorldOptions options;
};

// The arguments after the word `run` (or `generate`) into args: nullopt, or the message of a usage
// error (lslam-sim prints it and exits with status 2), which names the offending argument. The one
// positional argument (DATASET, OUT.g2o) may stand anywhere among the options. Usage errors: an
// unknown option (any argument starting with '-' that is no option), an option without its value
// (last on the line, or followed by an argument starting with "--"), an invalid value (parsed
// strictly: the whole token, numbers in range, paths not empty), an option given twice, a second
// positional argument, an empty one or none.
std::optional<std::string> parseRunArgs(const std::vector<std::string>& argv, RunArgs& args);
std::optional<std::string> parseGenerateArgs(const std::vector<std::string>& argv,
                                             GenerateArgs& args);
// WORLD must come first (its defaults are the options' starting values); then as above.
std::optional<std::string> parseSimulateArgs(const std::vector<std::string>& argv,
                                             SimulateArgs& args);
// `lslam-sim simulate --help`: the worlds and every option with its default; and the names of
// the options parseSimulateArgs takes (each one the help documents).
const char* simulateHelp();
std::vector<std::string> simulateOptionNames();

}  // namespace lslam::sim
