#pragma once
// A small writer of SVG documents: XML elements with attributes, nested by open/close, text
// content, the escaping of & < > " ' and numbers in a fixed, locale-independent form. Host-only;
// the map plot (map_plot.h) draws with it. It keeps the nesting balanced; what the elements mean
// is the caller's business.
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace lslam::sim {

// `v` with at most `decimals` digits after the point (rounded), trailing zeros and a bare point
// dropped, "-0" written as "0", always with '.' whatever the locale. Throws std::invalid_argument
// if `v` is not finite or `decimals` is outside [0, 9].
std::string formatSvgNumber(double v, int decimals = 2);

// `text` with & < > " ' replaced by entities: safe as text content and as a quoted attribute.
std::string escapeXml(std::string_view text);

// One attribute; the value is kept unescaped and escaped when written.
struct SvgAttribute {
  SvgAttribute(std::string n, std::string v) : name(std::move(n)), value(std::move(v)) {}
  SvgAttribute(std::string n, const char* v) : name(std::move(n)), value(v) {}
  SvgAttribute(std::string n, double v) : name(std::move(n)), value(formatSvgNumber(v)) {}
  SvgAttribute(std::string n, int v) : name(std::move(n)), value(std::to_string(v)) {}
  std::string name;
  std::string value;
};
using SvgAttributes = std::vector<SvgAttribute>;

class SvgWriter {
 public:
  // Starts the document: the XML declaration and the root <svg> in the SVG namespace, `width` by
  // `height` user units (viewBox "0 0 width height").
  SvgWriter(double width, double height);

  // <tag attributes...>, closed by close().
  void open(std::string_view tag, const SvgAttributes& attributes = {});
  // <tag attributes.../>
  void element(std::string_view tag, const SvgAttributes& attributes = {});
  // <tag attributes...>content</tag>, the content escaped.
  void text(std::string_view tag, const SvgAttributes& attributes, std::string_view content);
  // Closes the innermost element open(); std::logic_error if only the root is open.
  void close();
  // Closes every open element and the root; the whole document. The writer is spent afterwards
  // (std::logic_error on any further call).
  std::string finish();

 private:
  void startTag(std::string_view tag, const SvgAttributes& attributes);
  void requireOpen() const;
  void closeInnermost();

  std::string out_;
  std::vector<std::string> open_;  // the root first
};

}  // namespace lslam::sim
