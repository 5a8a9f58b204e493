#include "host_sim/svg_writer.h"

#include <array>
#include <charconv>
#include <cmath>
#include <stdexcept>

namespace lslam::sim {

std::string formatSvgNumber(double v, int decimals) {
  if (!std::isfinite(v)) throw std::invalid_argument("formatSvgNumber: not a finite number");
  if (decimals < 0 || decimals > 9) throw std::invalid_argument("formatSvgNumber: decimals");
  std::array<char, 400> buf{};  // the widest double in fixed form has 309 digits before the point
  const auto res =
      std::to_chars(buf.data(), buf.data() + buf.size(), v, std::chars_format::fixed, decimals);
  std::string s(buf.data(), res.ptr);
  if (s.find('.') != std::string::npos) {
    s.erase(s.find_last_not_of('0') + 1);
    if (s.back() == '.') s.pop_back();
  }
  return s == "-0" ? "0" : s;
}

std::string escapeXml(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

SvgWriter::SvgWriter(double width, double height) {
  out_ = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  const std::string w = formatSvgNumber(width);
  const std::string h = formatSvgNumber(height);
  startTag("svg", {{"xmlns", "http://www.w3.org/2000/svg"},
                   {"width", w},
                   {"height", h},
                   {"viewBox", "0 0 " + w + " " + h}});
  out_ += ">\n";
  open_.emplace_back("svg");
}

void SvgWriter::requireOpen() const {
  if (open_.empty()) throw std::logic_error("SvgWriter: the document is finished");
}

void SvgWriter::startTag(std::string_view tag, const SvgAttributes& attributes) {
  out_.append(2 * open_.size(), ' ');
  out_ += '<';
  out_ += tag;
  for (const SvgAttribute& a : attributes) {
    out_ += ' ' + a.name + "=\"" + escapeXml(a.value) + '"';
  }
}

void SvgWriter::open(std::string_view tag, const SvgAttributes& attributes) {
  requireOpen();
  startTag(tag, attributes);
  out_ += ">\n";
  open_.emplace_back(tag);
}

void SvgWriter::element(std::string_view tag, const SvgAttributes& attributes) {
  requireOpen();
  startTag(tag, attributes);
  out_ += "/>\n";
}

void SvgWriter::text(std::string_view tag, const SvgAttributes& attributes,
                     std::string_view content) {
  requireOpen();
  startTag(tag, attributes);
  out_ += '>' + escapeXml(content) + "</";
  out_ += tag;
  out_ += ">\n";
}

void SvgWriter::closeInnermost() {
  const std::string tag = std::move(open_.back());
  open_.pop_back();
  out_.append(2 * open_.size(), ' ');
  out_ += "</" + tag + ">\n";
}

void SvgWriter::close() {
  requireOpen();
  if (open_.size() == 1) throw std::logic_error("SvgWriter::close: only the root is open");
  closeInnermost();
}

std::string SvgWriter::finish() {
  requireOpen();
  while (!open_.empty()) closeInnermost();
  std::string document = std::move(out_);
  out_.clear();
  return document;
}

}  // namespace lslam::sim
