// Tests of the SVG writer (host_sim/svg_writer.h): number formatting, escaping, nesting.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "host_sim/svg_writer.h"

using lslam::sim::escapeXml;
using lslam::sim::formatSvgNumber;
using lslam::sim::SvgWriter;

TEST_CASE("formatSvgNumber: fixed decimals, no trailing zeros, no negative zero") {
  CHECK(formatSvgNumber(3.0) == "3");
  CHECK(formatSvgNumber(12.5) == "12.5");
  CHECK(formatSvgNumber(-2.346) == "-2.35");
  CHECK(formatSvgNumber(0.125, 3) == "0.125");
  CHECK(formatSvgNumber(-0.001) == "0");
  CHECK(formatSvgNumber(-0.0) == "0");
  CHECK(formatSvgNumber(1e6) == "1000000");
  CHECK(formatSvgNumber(1234.5678, 0) == "1235");
  CHECK(formatSvgNumber(100.0, 0) == "100");  // zeros before the point stay
  CHECK(formatSvgNumber(1e300).size() == 301);
  CHECK_THROWS_AS(formatSvgNumber(std::nan("")), std::invalid_argument);
  CHECK_THROWS_AS(formatSvgNumber(std::numeric_limits<double>::infinity()), std::invalid_argument);
  CHECK_THROWS_AS(formatSvgNumber(1.0, -1), std::invalid_argument);
}

TEST_CASE("escapeXml replaces the five special characters") {
  CHECK(escapeXml("a<b>&\"c'") == "a&lt;b&gt;&amp;&quot;c&apos;");
  CHECK(escapeXml("plain text") == "plain text");
}

TEST_CASE("SvgWriter nests elements and escapes attributes and text") {
  SvgWriter w(100, 50.5);
  w.open("g", {{"class", "a&b"}, {"n", 2}, {"x", 1.25}});
  w.element("circle", {{"r", 2.5}});
  w.text("text", {}, "<hi>");
  w.close();
  CHECK_THROWS_AS(w.close(), std::logic_error);  // only the root is open
  const std::string doc = w.finish();
  CHECK(doc ==
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"100\" height=\"50.5\" "
        "viewBox=\"0 0 100 50.5\">\n"
        "  <g class=\"a&amp;b\" n=\"2\" x=\"1.25\">\n"
        "    <circle r=\"2.5\"/>\n"
        "    <text>&lt;hi&gt;</text>\n"
        "  </g>\n"
        "</svg>\n");
  CHECK_THROWS_AS(w.element("rect"), std::logic_error);  // spent
  CHECK_THROWS_AS(w.finish(), std::logic_error);
}

TEST_CASE("SvgWriter::finish closes what is still open") {
  SvgWriter w(10, 10);
  w.open("g");
  w.open("g");
  const std::string doc = w.finish();
  const std::string tail = "    </g>\n  </g>\n</svg>\n";
  CHECK(doc.rfind(tail) == doc.size() - tail.size());
}
