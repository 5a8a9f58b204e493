#include "host_sim/cli_args.h"

#include <charconv>
#include <cmath>
#include <system_error>

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

}  // namespace lslam::sim
