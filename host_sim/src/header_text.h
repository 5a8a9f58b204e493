#pragma once
// The text of the generated stream headers (stream_header.cpp, model_stream_header.cpp): numbers
// that read back bit for bit, checked ids and identifiers. Private to host_sim/src.
#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <climits>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace lslam::sim::detail {

// The shortest text that reads back as the same value (double or float), with a decimal point.
template <class T>
std::string shortestLiteral(T v) {
  std::array<char, 32> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);  // shortest round trip
  std::string s(buf.data(), res.ptr);
  // A bare integer such as "400" is still a floating literal once it has a decimal point.
  if (s.find_first_of(".en") == std::string::npos) s += ".0";
  return s;
}

// The shortest text that reads back as the same double, always a double literal.
inline std::string doubleLiteral(double v) {
  return shortestLiteral(v);
}

// v rounded to float, as a float literal that reads back as that float.
inline std::string floatLiteral(double v) {
  return shortestLiteral(static_cast<float>(v)) + "f";
}

// v as text, for an id in 0..2^31-1; std::invalid_argument "<what> <v> out of range" otherwise.
inline std::string idLiteral(std::int64_t v, const std::string& what) {
  if (v < 0 || v > INT32_MAX) {
    throw std::invalid_argument(what + " " + std::to_string(v) + " out of range");
  }
  return std::to_string(v);
}

// std::invalid_argument "<who>: '<s>' is not a C++ identifier" unless it is one.
inline void checkIdentifier(const std::string& s, const std::string& who) {
  const bool ok = !s.empty() && std::isdigit(static_cast<unsigned char>(s[0])) == 0 &&
                  std::all_of(s.begin(), s.end(), [](char c) {
                    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_';
                  });
  if (!ok) throw std::invalid_argument(who + ": '" + s + "' is not a C++ identifier");
}

}  // namespace lslam::sim::detail
