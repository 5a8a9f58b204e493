#pragma once
// Helpers of the host command lines (lslam-sim): strict parsing of option values and JSON string
// literals. Host-only.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

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

}  // namespace lslam::sim
