#pragma once
// A small SVG writer for the report's plots: line plots, polar (ball-bar) plots, height maps, grouped
// bar charts and stacked panels (wavelet MRA). Every plot is one self-contained <svg> element with a
// fixed structure the tests and the report rely on:
//   <svg class="plot" data-plot="KIND" viewBox=...>
//     <text class="title">, <g class="axis x|y|polar|colorbar"> (ticks and tick labels),
//     <text class="axis-label"> (quantity / unit), <path class="data" data-series="LABEL"> (one per
//     series, bar or line; points outside the axes' range are clipped), <g class="legend">.
// Numbers are plotted in the units the caller passes (the labels say which). Pure functions; thread safe.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/number_format.hpp"

namespace guideway::report {

// Text for XML content and attribute values (& < > " '); control characters other than tab and line
// ends, C1 and bytes that are not UTF-8 become printable()'s visible escapes (\x1b).
[[nodiscard]] std::string xml_escape(std::string_view text);

// Tick positions for the range [lo, hi]: multiples of a 1-2-5 step, about `target` of them, covering
// the range (the first tick <= lo, the last >= hi). lo == hi gives a unit-wide range around it.
struct Ticks {
  double step = 1.0;
  std::vector<double> values;
  int decimals = 0;  // digits needed to print every tick distinctly
};
[[nodiscard]] Ticks nice_ticks(double lo, double hi, int target = 6);
// The smallest 1-2-5 number >= x (x > 0).
[[nodiscard]] double nice_ceil(double x);

// Linear map from data [d0, d1] to pixels [p0, p1] (p1 < p0 for a y axis pointing up).
struct Scale {
  double d0 = 0.0, d1 = 1.0, p0 = 0.0, p1 = 1.0;
  [[nodiscard]] double operator()(double v) const { return p0 + (v - d0) * (p1 - p0) / (d1 - d0); }
};

enum class Style { line, dashed, markers, line_markers };

// One data series; NaN values break the line.
struct Series {
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
  std::string color;  // CSS colour; empty = the palette colour of the series' index
  Style style = Style::line;
  double width = 1.4;
};

struct Range {
  double lo = 0.0;
  double hi = 1.0;
};

// A band between two curves (an uncertainty band: value -+ 2 u), drawn under the series, filled.
struct Band {
  std::string label;  // its legend entry ("" for none)
  std::vector<double> x, lo, hi;
  std::string color;  // CSS colour; empty = the palette colour of its index
};

struct LinePlot {
  std::string title;
  std::string x_label;  // "quantity / unit"
  std::string y_label;
  std::vector<Series> series;
  std::vector<Band> bands;  // <path class="band">, each with its series' colour when the index matches
  std::optional<Range> x_range;  // default: the data's extent
  std::optional<Range> y_range;  // default: the data's extent, rounded out to ticks
  double width = 760;
  double height = 300;
};
[[nodiscard]] std::string render(const LinePlot& plot);

// Several panels sharing the x axis (Mu's Figure 7: s, a5, d5..d1); one series per panel, each with
// its own y axis; the x tick labels and the x label are on the bottom panel.
struct StackedPanels {
  std::string title;
  std::string x_label;
  std::vector<Series> panels;  // the series label is the panel's y label
  std::string y_unit;          // appended to each panel label: "a5 / um"
  double width = 760;
  double panel_height = 78;
};
[[nodiscard]] std::string render(const StackedPanels& plot);

// A ball-bar polar plot: the deviation d(theta) is drawn at radius nominal + d * (division / um_per_div),
// rings every division from -divisions to +divisions around the nominal circle.
struct PolarSeries {
  std::string label;
  std::vector<double> angle_rad;
  std::vector<double> deviation_um;
  std::string color;
};
struct PolarPlot {
  std::string title;
  std::vector<PolarSeries> series;
  double um_per_div = 0.0;   // 0: the 1-2-5 value that lets the points fill the rings (polar_scale)
  int divisions = 0;         // rings each side of the bold one; 0: 3 to 5, whichever fills best
  std::string axis_a = "X";  // labels of the first and second plane axis (0 deg and 90 deg)
  std::string axis_b = "Y";
  std::string quantity = "\u0394L";  // what is plotted radially
  std::string zero_ring = "0";       // what the bold ring is
  double size = 520;
};
// The scale chosen for these series: um per division and divisions each side of the bold ring. Auto:
// the 1-2-5 step of about a fifth of the largest |deviation|, and as many divisions (3 to 5) as keep
// every point inside with a little room, so the largest deviation reaches 64 % to 97 % of the way out.
struct PolarScale {
  double um_per_div = 1.0;
  int divisions = 4;
};
[[nodiscard]] PolarScale polar_scale(const PolarPlot& plot);
[[nodiscard]] inline double polar_um_per_div(const PolarPlot& plot) { return polar_scale(plot).um_per_div; }
[[nodiscard]] std::string render(const PolarPlot& plot);

// Scattered heights (e.g. the stations of a Union Jack set) shown as a colour map interpolated by
// inverse distance weighting over their bounding box, with the stations and the measuring lines on
// top and a colour bar with the height scale.
struct HeightMap {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::string z_label;  // colour bar: "height / um"
  std::vector<double> x, y, z;
  std::vector<std::vector<std::size_t>> lines;  // polylines through station indices
  std::vector<std::string> line_labels;         // one per line (data-series attribute)
  double width = 760;
};
[[nodiscard]] std::string render(const HeightMap& map);

// Grouped bars: one group per category, one bar per series in each group.
struct BarSeries {
  std::string label;
  std::vector<double> values;  // one per category; NaN = no bar
  std::string color;
};
struct BarChart {
  std::string title;
  std::string x_label;  // what the categories are
  std::string y_label;  // the values' quantity / unit
  std::vector<std::string> categories;
  std::vector<BarSeries> series;
  std::optional<Range> y_range;  // default: from min(0, data) to max(0, data)
  double width = 760;
  double height = 300;  // horizontal: from the number of categories
  // Horizontal bars, a category per row with its label left of it (a ranking): labels of any length
  // never overlap, as each has its own row and the label column is as wide as the longest. The value
  // axis (y_label) is then the horizontal one, at the bottom; x_label names the categories.
  bool horizontal = false;
};
[[nodiscard]] std::string render(const BarChart& chart);

// Error vectors on a face or slice of the working volume: an arrow per point of the face (its in-plane components,
// magnified so the longest spans about a grid cell), coloured by the component out of the plane; a scale arrow
// in the legend and a colour bar for the out-of-plane component.
struct VectorField {
  std::string title;
  std::string x_label;  // the face's axes, "X / mm"
  std::string y_label;
  std::vector<double> x, y;  // arrow tails, in the axes' units
  std::vector<double> u, v;  // in-plane components (vector_unit)
  std::vector<double> w;     // out of the plane (vector_unit); empty: none
  std::string vector_unit = "\u00b5m";
  std::string w_label;  // colour bar: "Z error / um"
  double width = 380;
};
[[nodiscard]] std::string render(const VectorField& field);

// The palette (colour-blind safe, distinct in greyscale print order).
[[nodiscard]] const std::string& palette(std::size_t index);

}  // namespace guideway::report
