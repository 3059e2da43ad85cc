// A small SVG writer for the report's plots (svg.hpp): line, polar, height-map, bar and stacked plots, each one <svg>
// element.
#include "report/svg.hpp"

#include "core/printable.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace guideway::report {

namespace {

constexpr double kTitleHeight = 26;
constexpr double kLegendRow = 18;
constexpr double kCharWidth = 6.6;       // average advance of a 12 px sans-serif character, for layout only
constexpr double kLabelCharWidth = 7.6;  // the widest likely advance (capitals, DejaVu Sans 12 px): room for labels

// Unique ids for clip paths: inline SVGs of one HTML page share the id namespace.
std::string next_id(const char* prefix) {
  static std::atomic<unsigned> counter{0};
  return std::string(prefix) + std::to_string(++counter);
}

std::string px(double v) { return format_fixed(v, 1); }

// Characters of UTF-8 text (for layout: "µ" is one).
std::size_t display_chars(std::string_view text) {
  return static_cast<std::size_t>(std::count_if(text.begin(), text.end(), [](char c) { return (c & 0xC0) != 0x80; }));
}

struct Frame {
  double left, top, right, bottom;
  [[nodiscard]] double w() const { return right - left; }
  [[nodiscard]] double h() const { return bottom - top; }
};

std::string open_svg(const char* kind, double width, double height, const std::string& title) {
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"plot\" data-plot=\"" << kind << "\" viewBox=\"0 0 "
    << px(width) << ' ' << px(height) << "\" width=\"" << px(width) << "\" height=\"" << px(height)
    << "\" role=\"img\" aria-label=\"" << xml_escape(title) << "\" font-family=\"DejaVu Sans, Arial, sans-serif\""
    << " font-size=\"12\">";
  o << "<title>" << xml_escape(title) << "</title>";
  o << "<rect class=\"background\" x=\"0\" y=\"0\" width=\"" << px(width) << "\" height=\"" << px(height)
    << "\" fill=\"#ffffff\"/>";
  if (!title.empty())
    o << "<text class=\"title\" x=\"" << px(width / 2) << "\" y=\"18\" text-anchor=\"middle\" font-size=\"14\""
      << " font-weight=\"bold\">" << xml_escape(title) << "</text>";
  return o.str();
}

std::string dash_attr(Style style) { return style == Style::dashed ? " stroke-dasharray=\"6 4\"" : ""; }

struct LegendItem {
  std::string label;
  std::string color;
  Style style = Style::line;
  bool swatch = false;  // a filled box (bars) instead of a line sample
};

// Lays the legend out in rows under the title; returns the rows used.
int legend_rows(const std::vector<LegendItem>& items, double left, double right) {
  if (items.empty()) return 0;
  int rows = 1;
  double x = left;
  for (const auto& it : items) {
    const double w = 30 + kCharWidth * static_cast<double>(it.label.size()) + 16;
    if (x + w > right && x > left) {
      ++rows;
      x = left;
    }
    x += w;
  }
  return rows;
}

std::string legend(const std::vector<LegendItem>& items, double left, double right, double top) {
  if (items.empty()) return {};
  std::ostringstream o;
  o << "<g class=\"legend\">";
  double x = left;
  double y = top + 12;
  for (const auto& it : items) {
    const double w = 30 + kCharWidth * static_cast<double>(it.label.size()) + 16;
    if (x + w > right && x > left) {
      x = left;
      y += kLegendRow;
    }
    o << "<g class=\"legend-item\">";
    if (it.swatch) {
      o << "<rect x=\"" << px(x + 6) << "\" y=\"" << px(y - 9) << "\" width=\"14\" height=\"10\" fill=\"" << it.color
        << "\"/>";
    } else if (it.style == Style::markers) {
      o << "<circle cx=\"" << px(x + 13) << "\" cy=\"" << px(y - 4) << "\" r=\"3\" fill=\"" << it.color << "\"/>";
    } else {
      o << "<line x1=\"" << px(x) << "\" y1=\"" << px(y - 4) << "\" x2=\"" << px(x + 26) << "\" y2=\"" << px(y - 4)
        << "\" stroke=\"" << it.color << "\" stroke-width=\"2.2\"" << dash_attr(it.style) << "/>";
      if (it.style == Style::line_markers)
        o << "<circle cx=\"" << px(x + 13) << "\" cy=\"" << px(y - 4) << "\" r=\"2.6\" fill=\"" << it.color << "\"/>";
    }
    o << "<text x=\"" << px(x + 30) << "\" y=\"" << px(y) << "\">" << xml_escape(it.label) << "</text></g>";
    x += w;
  }
  o << "</g>";
  return o.str();
}

// A horizontal axis at pixel row y with ticks and labels; grid lines up to `grid_top` when > 0.
std::string x_axis(const Scale& s, const Ticks& t, double y, double grid_top, bool labels, const std::string& label,
                   double label_x, double label_y) {
  std::ostringstream o;
  o << "<g class=\"axis x\">";
  const double lo = std::min(s.d0, s.d1), hi = std::max(s.d0, s.d1);
  const double eps = 1e-9 * (hi - lo);
  for (double v : t.values) {
    if (v < lo - eps || v > hi + eps) continue;
    const double p = s(v);
    if (grid_top > 0)
      o << "<line class=\"grid\" x1=\"" << px(p) << "\" y1=\"" << px(grid_top) << "\" x2=\"" << px(p) << "\" y2=\""
        << px(y) << "\" stroke=\"#e3e3e3\"/>";
    o << "<line class=\"tick\" x1=\"" << px(p) << "\" y1=\"" << px(y) << "\" x2=\"" << px(p) << "\" y2=\"" << px(y + 5)
      << "\" stroke=\"#333\"/>";
    if (labels)
      o << "<text class=\"tick-label\" x=\"" << px(p) << "\" y=\"" << px(y + 18) << "\" text-anchor=\"middle\">"
        << format_fixed(v, t.decimals) << "</text>";
  }
  o << "<line class=\"axis-line\" x1=\"" << px(s.p0) << "\" y1=\"" << px(y) << "\" x2=\"" << px(s.p1) << "\" y2=\""
    << px(y) << "\" stroke=\"#333\"/>";
  o << "</g>";
  if (!label.empty())
    o << "<text class=\"axis-label x\" x=\"" << px(label_x) << "\" y=\"" << px(label_y)
      << "\" text-anchor=\"middle\" font-size=\"13\">" << xml_escape(label) << "</text>";
  return o.str();
}

// A vertical axis at pixel column x with ticks and labels; grid lines to `grid_right` when > 0.
std::string y_axis(const Scale& s, const Ticks& t, double x, double grid_right, const std::string& label,
                   double label_x, const char* cls = "axis y", bool label_right = false) {
  std::ostringstream o;
  o << "<g class=\"" << cls << "\">";
  const double lo = std::min(s.d0, s.d1), hi = std::max(s.d0, s.d1);
  const double eps = 1e-9 * (hi - lo);
  const double dir = label_right ? 1 : -1;
  for (double v : t.values) {
    if (v < lo - eps || v > hi + eps) continue;
    const double p = s(v);
    if (grid_right > 0)
      o << "<line class=\"grid\" x1=\"" << px(x) << "\" y1=\"" << px(p) << "\" x2=\"" << px(grid_right) << "\" y2=\""
        << px(p) << "\" stroke=\"#e3e3e3\"/>";
    o << "<line class=\"tick\" x1=\"" << px(x) << "\" y1=\"" << px(p) << "\" x2=\"" << px(x + 5 * dir) << "\" y2=\""
      << px(p) << "\" stroke=\"#333\"/>";
    o << "<text class=\"tick-label\" x=\"" << px(x + 8 * dir) << "\" y=\"" << px(p + 4) << "\" text-anchor=\""
      << (label_right ? "start" : "end") << "\">" << format_fixed(v, t.decimals) << "</text>";
  }
  o << "<line class=\"axis-line\" x1=\"" << px(x) << "\" y1=\"" << px(s.p0) << "\" x2=\"" << px(x) << "\" y2=\""
    << px(s.p1) << "\" stroke=\"#333\"/>";
  o << "</g>";
  if (!label.empty()) {
    const double cy = (s.p0 + s.p1) / 2;
    o << "<text class=\"axis-label y\" x=\"" << px(label_x) << "\" y=\"" << px(cy) << "\" text-anchor=\"middle\""
      << " font-size=\"13\" transform=\"rotate(-90 " << px(label_x) << ' ' << px(cy) << ")\">" << xml_escape(label)
      << "</text>";
  }
  return o.str();
}

std::string clip_rect(const std::string& id, const Frame& f) {
  return "<clipPath id=\"" + id + "\"><rect x=\"" + px(f.left) + "\" y=\"" + px(f.top) + "\" width=\"" + px(f.w()) +
         "\" height=\"" + px(f.h()) + "\"/></clipPath>";
}

// Keeps at most ~4 points per pixel column (first, min, max, last) so long profiles stay small.
void decimate(const std::vector<double>& xs, const std::vector<double>& ys, const Scale& sx, std::vector<double>& ox,
              std::vector<double>& oy, double width_px) {
  const std::size_t n = std::min(xs.size(), ys.size());
  if (static_cast<double>(n) <= 4 * width_px) {
    ox.assign(xs.begin(), xs.begin() + static_cast<std::ptrdiff_t>(n));
    oy.assign(ys.begin(), ys.begin() + static_cast<std::ptrdiff_t>(n));
    return;
  }
  std::size_t i = 0;
  while (i < n) {
    const long col = std::isfinite(xs[i]) ? std::lround(std::floor(sx(xs[i]))) : -1;
    std::size_t j = i;
    std::size_t imin = i, imax = i;
    while (j < n && std::isfinite(xs[j]) && std::lround(std::floor(sx(xs[j]))) == col) {
      if (!std::isfinite(ys[j])) break;  // handled as a break below
      if (ys[j] < ys[imin]) imin = j;
      if (ys[j] > ys[imax]) imax = j;
      ++j;
    }
    if (j == i) {  // a NaN point: keep it as a break
      ox.push_back(xs[i]);
      oy.push_back(std::numeric_limits<double>::quiet_NaN());
      ++i;
      continue;
    }
    std::array<std::size_t, 4> keep = {i, std::min(imin, imax), std::max(imin, imax), j - 1};
    std::size_t last = n;
    for (std::size_t k : keep) {
      if (k == last) continue;
      ox.push_back(xs[k]);
      oy.push_back(ys[k]);
      last = k;
    }
    i = j;
  }
}

std::string line_path_d(const std::vector<double>& xs, const std::vector<double>& ys, const Scale& sx,
                        const Scale& sy) {
  std::string d;
  bool pen_down = false;
  for (std::size_t i = 0; i < xs.size() && i < ys.size(); ++i) {
    if (!std::isfinite(xs[i]) || !std::isfinite(ys[i])) {
      pen_down = false;
      continue;
    }
    d += pen_down ? " L" : (d.empty() ? "M" : " M");
    d += format_fixed(sx(xs[i]), 2) + ' ' + format_fixed(sy(ys[i]), 2);
    pen_down = true;
  }
  return d;
}

std::string marker_path_d(const std::vector<double>& xs, const std::vector<double>& ys, const Scale& sx,
                          const Scale& sy, double r) {
  std::string d;
  for (std::size_t i = 0; i < xs.size() && i < ys.size(); ++i) {
    if (!std::isfinite(xs[i]) || !std::isfinite(ys[i])) continue;
    if (!d.empty()) d += ' ';
    d += 'M' + format_fixed(sx(xs[i]) - r, 2) + ' ' + format_fixed(sy(ys[i]), 2) + " a" + format_fixed(r, 2) + ' ' +
         format_fixed(r, 2) + " 0 1 0 " + format_fixed(2 * r, 2) + " 0 a" + format_fixed(r, 2) + ' ' +
         format_fixed(r, 2) + " 0 1 0 " + format_fixed(-2 * r, 2) + " 0";
  }
  return d;
}

std::string series_path(const Series& s, const std::string& color, const Scale& sx, const Scale& sy, double width_px) {
  std::ostringstream o;
  const bool line = s.style != Style::markers;
  const bool markers = s.style == Style::markers || s.style == Style::line_markers;
  if (line) {
    std::vector<double> xs, ys;
    decimate(s.x, s.y, sx, xs, ys, width_px);
    o << "<path class=\"data\" data-series=\"" << xml_escape(s.label) << "\" data-points=\"" << xs.size() << "\" d=\""
      << line_path_d(xs, ys, sx, sy) << "\" fill=\"none\" stroke=\"" << color << "\" stroke-width=\""
      << format_fixed(s.width, 1) << "\" stroke-linejoin=\"round\"" << dash_attr(s.style) << "/>";
  }
  if (markers) {
    o << "<path class=\"" << (line ? "markers" : "data") << "\" data-series=\"" << xml_escape(s.label)
      << "\" data-points=\"" << s.x.size() << "\" d=\"" << marker_path_d(s.x, s.y, sx, sy, 2.6) << "\" fill=\"" << color
      << "\" stroke=\"none\"/>";
  }
  return o.str();
}

void extent(const std::vector<double>& v, double& lo, double& hi) {
  for (double a : v)
    if (std::isfinite(a)) {
      lo = std::min(lo, a);
      hi = std::max(hi, a);
    }
}

Range widen(double lo, double hi) {
  if (!(lo <= hi)) return {0.0, 1.0};  // no finite data
  if (lo == hi) {
    const double h = lo == 0 ? 0.5 : std::abs(lo) * 0.05;
    return {lo - h, hi + h};
  }
  return {lo, hi};
}

// Viridis, 9 anchors; t in [0, 1].
std::string colormap(double t) {
  static constexpr std::array<std::array<int, 3>, 9> anchors = {{{68, 1, 84},
                                                                 {71, 44, 122},
                                                                 {59, 81, 139},
                                                                 {44, 113, 142},
                                                                 {33, 144, 141},
                                                                 {39, 173, 129},
                                                                 {92, 200, 99},
                                                                 {170, 220, 50},
                                                                 {253, 231, 37}}};
  t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0) * 8.0;
  const auto i = std::min<std::size_t>(7, static_cast<std::size_t>(t));
  const double f = t - static_cast<double>(i);
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x",
                static_cast<int>(std::lround(anchors[i][0] + f * (anchors[i + 1][0] - anchors[i][0]))),
                static_cast<int>(std::lround(anchors[i][1] + f * (anchors[i + 1][1] - anchors[i][1]))),
                static_cast<int>(std::lround(anchors[i][2] + f * (anchors[i + 1][2] - anchors[i][2]))));
  return buf;
}

}  // namespace

std::string xml_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  // Control characters (but tab and line ends), C1 and bytes that are not UTF-8 as printable()'s visible
  // escapes: XML forbids them, and a broker's ESC or BEL would otherwise reach whoever reads the page.
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t end = text.find_first_of("\t\n\r&<>\"'", i);
    const std::string_view run = text.substr(i, end == std::string_view::npos ? std::string_view::npos : end - i);
    out += printable(run);
    if (end == std::string_view::npos) break;
    switch (text[end]) {
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
        out += "&#39;";
        break;
      default:
        out += text[end];  // tab, line end
    }
    i = end + 1;
  }
  return out;
}

double nice_ceil(double x) {
  if (!(x > 0) || !std::isfinite(x)) throw std::invalid_argument("nice_ceil: needs a positive finite number");
  const double e = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * e >= x * (1 - 1e-12)) return m * e;
  return 10 * e;
}

Ticks nice_ticks(double lo, double hi, int target) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) throw std::invalid_argument("nice_ticks: range is not finite");
  if (lo > hi) std::swap(lo, hi);
  // A span below the resolution of the numbers would give thousands of ticks: widen it.
  const double min_span = std::max(1e-300, 1e-9 * std::max(std::abs(lo), std::abs(hi)));
  if (hi - lo < min_span) {
    const double h = lo == 0 && hi == 0 ? 0.5 : std::max(min_span, 0.05 * std::abs(lo));
    lo -= h;
    hi += h;
  }
  Ticks t;
  t.step = nice_ceil((hi - lo) / std::max(1, target));
  const double first = std::floor(lo / t.step + 1e-9);
  const double last = std::ceil(hi / t.step - 1e-9);
  for (double k = first; k <= last; k += 1) t.values.push_back(k * t.step);
  t.decimals = std::max(0, -static_cast<int>(std::floor(std::log10(t.step) + 1e-9)));
  return t;
}

const std::string& palette(std::size_t index) {
  static const std::array<std::string, 8> colors = {"#0072b2", "#d55e00", "#009e73", "#cc79a7",
                                                    "#e69f00", "#56b4e9", "#000000", "#999999"};
  return colors[index % colors.size()];
}

std::string render(const LinePlot& plot) {
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
  for (const auto& s : plot.series) {
    extent(s.x, xlo, xhi);
    extent(s.y, ylo, yhi);
  }
  for (const auto& b : plot.bands) {
    extent(b.x, xlo, xhi);
    extent(b.lo, ylo, yhi);
    extent(b.hi, ylo, yhi);
  }
  const Range xr = plot.x_range ? *plot.x_range : widen(xlo, xhi);
  Ticks yt;
  Range yr;
  if (plot.y_range) {
    yr = *plot.y_range;
    yt = nice_ticks(yr.lo, yr.hi);
  } else {
    const Range d = widen(ylo, yhi);
    yt = nice_ticks(d.lo, d.hi);
    yr = {yt.values.front(), yt.values.back()};
  }
  const Ticks xt = nice_ticks(xr.lo, xr.hi, 8);

  std::vector<LegendItem> items;
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const auto& s = plot.series[i];
    if (!s.label.empty()) items.push_back({s.label, s.color.empty() ? palette(i) : s.color, s.style, false});
  }
  const auto band_color = [&](std::size_t i) {
    return plot.bands[i].color.empty() ? palette(i) : plot.bands[i].color;
  };
  for (std::size_t i = 0; i < plot.bands.size(); ++i)
    if (!plot.bands[i].label.empty()) items.push_back({plot.bands[i].label, band_color(i), Style::line, true});
  const int rows = legend_rows(items, 70, plot.width - 16);
  Frame f{72, kTitleHeight + rows * kLegendRow + 8, plot.width - 18, plot.height - 46};
  const Scale sx{xr.lo, xr.hi, f.left, f.right};
  const Scale sy{yr.lo, yr.hi, f.bottom, f.top};

  std::ostringstream o;
  o << open_svg("line", plot.width, plot.height, plot.title);
  o << legend(items, f.left, plot.width - 16, kTitleHeight);
  o << x_axis(sx, xt, f.bottom, f.top, true, plot.x_label, (f.left + f.right) / 2, plot.height - 8);
  o << y_axis(sy, yt, f.left, f.right, plot.y_label, 16);
  const std::string clip = next_id("clip");
  o << "<defs>" << clip_rect(clip, f) << "</defs><g class=\"series\" clip-path=\"url(#" << clip << ")\">";
  for (std::size_t i = 0; i < plot.bands.size(); ++i) {
    const Band& b = plot.bands[i];
    std::string d;
    const std::size_t n = std::min({b.x.size(), b.lo.size(), b.hi.size()});
    for (std::size_t k = 0; k < n; ++k)
      d += (d.empty() ? "M" : " L") + format_fixed(sx(b.x[k]), 2) + ' ' + format_fixed(sy(b.hi[k]), 2);
    for (std::size_t k = n; k-- > 0;) d += " L" + format_fixed(sx(b.x[k]), 2) + ' ' + format_fixed(sy(b.lo[k]), 2);
    if (n > 0) d += " Z";
    o << "<path class=\"band\" data-series=\"" << xml_escape(b.label) << "\" d=\"" << d << "\" fill=\"" << band_color(i)
      << "\" fill-opacity=\"0.18\" stroke=\"none\"/>";
  }
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const auto& s = plot.series[i];
    o << series_path(s, s.color.empty() ? palette(i) : s.color, sx, sy, f.w());
  }
  o << "</g><rect class=\"frame\" x=\"" << px(f.left) << "\" y=\"" << px(f.top) << "\" width=\"" << px(f.w())
    << "\" height=\"" << px(f.h()) << "\" fill=\"none\" stroke=\"#333\"/></svg>";
  return o.str();
}

std::string render(const StackedPanels& plot) {
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo;
  for (const auto& s : plot.panels) extent(s.x, xlo, xhi);
  const Range xr = widen(xlo, xhi);
  const Ticks xt = nice_ticks(xr.lo, xr.hi, 8);
  const double top0 = kTitleHeight + 6;
  const double gap = 16;  // keeps the tick labels of neighbouring panels apart
  const double height = top0 + static_cast<double>(plot.panels.size()) * (plot.panel_height + gap) + 46;
  const double left = 92, right = plot.width - 18;
  const Scale sx{xr.lo, xr.hi, left, right};

  std::ostringstream o;
  o << open_svg("panels", plot.width, height, plot.title);
  for (std::size_t i = 0; i < plot.panels.size(); ++i) {
    const auto& s = plot.panels[i];
    const Frame f{left, top0 + static_cast<double>(i) * (plot.panel_height + gap), right,
                  top0 + static_cast<double>(i) * (plot.panel_height + gap) + plot.panel_height};
    double ylo = std::numeric_limits<double>::infinity(), yhi = -ylo;
    extent(s.y, ylo, yhi);
    const Range d = widen(ylo, yhi);
    const Ticks yt = nice_ticks(d.lo, d.hi, 3);
    const Scale sy{yt.values.front(), yt.values.back(), f.bottom, f.top};
    const bool last = i + 1 == plot.panels.size();
    o << "<g class=\"panel\" data-panel=\"" << xml_escape(s.label) << "\">";
    o << x_axis(sx, xt, f.bottom, f.top, last, last ? plot.x_label : std::string(), (left + right) / 2, height - 8);
    const std::string label = plot.y_unit.empty() ? s.label : s.label + " / " + plot.y_unit;
    o << y_axis(sy, yt, f.left, f.right, label, 18);
    const std::string clip = next_id("clip");
    o << "<defs>" << clip_rect(clip, f) << "</defs><g class=\"series\" clip-path=\"url(#" << clip << ")\">";
    o << series_path(s, s.color.empty() ? palette(0) : s.color, sx, sy, f.w());
    o << "</g><rect class=\"frame\" x=\"" << px(f.left) << "\" y=\"" << px(f.top) << "\" width=\"" << px(f.w())
      << "\" height=\"" << px(f.h()) << "\" fill=\"none\" stroke=\"#333\"/></g>";
  }
  o << "</svg>";
  return o.str();
}

PolarScale polar_scale(const PolarPlot& plot) {
  double m = 0;
  for (const auto& s : plot.series)
    for (double d : s.deviation_um)
      if (std::isfinite(d)) m = std::max(m, std::abs(d));
  PolarScale out;
  if (plot.divisions > 0) out.divisions = plot.divisions;
  if (plot.um_per_div > 0) {
    out.um_per_div = plot.um_per_div;
    if (plot.divisions <= 0) out.divisions = std::clamp(static_cast<int>(std::ceil(m / plot.um_per_div + 0.15)), 3, 5);
    return out;
  }
  if (m == 0) return out;
  if (plot.divisions > 0) {
    // Keep a fifth of a division free at the outer ring.
    const int div = plot.divisions;
    out.um_per_div = nice_ceil(m / (div - 0.2 + (div == 1 ? 0.1 : 0.0)));
    return out;
  }
  out.um_per_div = nice_ceil(m / 4.8);
  out.divisions = std::max(3, static_cast<int>(std::ceil(m / out.um_per_div + 0.15)));
  return out;
}

std::string render(const PolarPlot& plot) {
  const PolarScale scale = polar_scale(plot);
  const int div = std::max(1, scale.divisions);
  const double per_div = scale.um_per_div;
  std::vector<LegendItem> items;
  for (std::size_t i = 0; i < plot.series.size(); ++i)
    items.push_back(
        {plot.series[i].label, plot.series[i].color.empty() ? palette(i) : plot.series[i].color, Style::line, false});
  const int rows = legend_rows(items, 20, plot.size - 20);
  const double top = kTitleHeight + rows * kLegendRow + 6;
  const double outer = (plot.size - 170) / 2;  // room for the angle labels ("180° −X") on both sides
  const double nominal = outer * 0.55;
  const double div_px = (outer - nominal) / div;
  const double cx = plot.size / 2, cy = top + 30 + outer;
  const double height = cy + outer + 72;  // the 270° label, then the two axis labels under it
  const auto radius = [&](double dev_um) { return nominal + dev_um / per_div * div_px; };

  std::ostringstream o;
  o << open_svg("polar", plot.size, height, plot.title);
  o << legend(items, 20, plot.size - 20, kTitleHeight);
  o << "<g class=\"axis polar\">";
  for (int k = -div; k <= div; ++k) {
    const double r = radius(k * per_div);
    o << "<circle class=\"" << (k == 0 ? "nominal" : "ring") << "\" cx=\"" << px(cx) << "\" cy=\"" << px(cy)
      << "\" r=\"" << px(r) << "\" fill=\"none\" stroke=\"" << (k == 0 ? "#555" : "#d0d0d0") << "\" stroke-width=\""
      << (k == 0 ? "1.2" : "0.8") << "\"/>";
  }
  for (int a = 0; a < 360; a += 30) {
    const double t = a * std::numbers::pi / 180;
    const double r0 = radius(-div * per_div);
    o << "<line class=\"spoke\" x1=\"" << px(cx + r0 * std::cos(t)) << "\" y1=\"" << px(cy - r0 * std::sin(t))
      << "\" x2=\"" << px(cx + outer * std::cos(t)) << "\" y2=\"" << px(cy - outer * std::sin(t))
      << "\" stroke=\"#d0d0d0\" stroke-width=\"0.8\"/>";
    std::string label = std::to_string(a) + "\u00b0";
    if (a == 0) label += " +" + plot.axis_a;
    if (a == 90) label += " +" + plot.axis_b;
    if (a == 180) label += " \u2212" + plot.axis_a;
    if (a == 270) label += " \u2212" + plot.axis_b;
    const double rl = outer + 16;
    const double lx = cx + rl * std::cos(t), ly = cy - rl * std::sin(t) + 4;
    const char* anchor = std::abs(std::cos(t)) < 0.3 ? "middle" : (std::cos(t) > 0 ? "start" : "end");
    o << "<text class=\"tick-label\" x=\"" << px(lx) << "\" y=\"" << px(ly) << "\" text-anchor=\"" << anchor << "\">"
      << xml_escape(label) << "</text>";
  }
  // Ring values along the 75 deg direction, where no spoke runs; every other ring's when the rings are
  // closer than two lines of its 10 px text (a ring label over each 13 px ring ran into the next).
  const double tl = 75 * std::numbers::pi / 180;
  const int label_every = div_px < 20 ? 2 : 1;
  for (int k = -div; k <= div; ++k) {
    if (k % label_every != 0) continue;
    const double r = radius(k * per_div);
    const double v = k * per_div;
    const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(per_div) + 1e-9)));
    const std::string text = (v > 0 ? "+" : "") + format_fixed(v, decimals);
    o << "<text class=\"tick-label ring-label\" x=\"" << px(cx + r * std::cos(tl)) << "\" y=\""
      << px(cy - r * std::sin(tl) + 4) << "\" text-anchor=\"middle\" font-size=\"10\" fill=\"#555\">"
      << xml_escape(text) << "</text>";
  }
  o << "</g>";
  const std::string clip = next_id("clip");
  o << "<defs><clipPath id=\"" << clip << "\"><circle cx=\"" << px(cx) << "\" cy=\"" << px(cy) << "\" r=\""
    << px(outer + div_px * 0.5) << "\"/></clipPath></defs>";
  o << "<g class=\"series\" clip-path=\"url(#" << clip << ")\">";
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const auto& s = plot.series[i];
    std::string d;
    bool pen = false;
    for (std::size_t k = 0; k < s.angle_rad.size() && k < s.deviation_um.size(); ++k) {
      if (!std::isfinite(s.angle_rad[k]) || !std::isfinite(s.deviation_um[k])) {
        pen = false;
        continue;
      }
      const double r = std::max(0.0, radius(s.deviation_um[k]));
      d += pen ? " L" : (d.empty() ? "M" : " M");
      d +=
          format_fixed(cx + r * std::cos(s.angle_rad[k]), 2) + ' ' + format_fixed(cy - r * std::sin(s.angle_rad[k]), 2);
      pen = true;
    }
    o << "<path class=\"data\" data-series=\"" << xml_escape(s.label) << "\" data-points=\"" << s.angle_rad.size()
      << "\" d=\"" << d << "\" fill=\"none\" stroke=\"" << (s.color.empty() ? palette(i) : s.color)
      << "\" stroke-width=\"1.4\" stroke-linejoin=\"round\"/>";
  }
  o << "</g>";
  o << "<text class=\"axis-label\" x=\"" << px(cx) << "\" y=\"" << px(height - 30)
    << "\" text-anchor=\"middle\" font-size=\"13\">angle \u03b6 / deg (from +" << xml_escape(plot.axis_a)
    << " towards +" << xml_escape(plot.axis_b) << ")</text>";
  o << "<text class=\"axis-label scale\" x=\"" << px(cx) << "\" y=\"" << px(height - 12)
    << "\" text-anchor=\"middle\" font-size=\"13\">radial: " << xml_escape(plot.quantity) << " / \u00b5m, "
    << format_number(per_div, 3) << " \u00b5m/div (bold ring: " << xml_escape(plot.zero_ring) << ")</text>";
  o << "</svg>";
  return o.str();
}

std::string render(const HeightMap& map) {
  const std::size_t n = std::min({map.x.size(), map.y.size(), map.z.size()});
  if (n == 0) throw std::invalid_argument("height map: no points");
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo, zlo = xlo, zhi = -xlo;
  extent(map.x, xlo, xhi);
  extent(map.y, ylo, yhi);
  extent(map.z, zlo, zhi);
  const Range xr = widen(xlo, xhi), yr = widen(ylo, yhi);
  const Ticks zt = nice_ticks(zlo, zhi, 6);
  const Range zr{zt.values.front(), zt.values.back()};

  const double left = 78, bar_w = 130;
  double pw = map.width - left - bar_w;
  double ph = pw * (yr.hi - yr.lo) / (xr.hi - xr.lo);
  if (ph > 440) {
    pw *= 440 / ph;
    ph = 440;
  }
  const Frame f{left, kTitleHeight + 14, left + pw, kTitleHeight + 14 + ph};
  const double height = f.bottom + 52;
  const Scale sx{xr.lo, xr.hi, f.left, f.right};
  const Scale sy{yr.lo, yr.hi, f.bottom, f.top};

  std::ostringstream o;
  o << open_svg("heightmap", map.width, height, map.title);
  // Inverse-distance-weighted colour cells (power 2): a smooth view of scattered stations.
  o << "<g class=\"map\" shape-rendering=\"crispEdges\">";
  const int nx = 56;
  const int ny = std::max(4, static_cast<int>(std::lround(nx * ph / pw)));
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double gx = xr.lo + (i + 0.5) * (xr.hi - xr.lo) / nx;
      const double gy = yr.lo + (j + 0.5) * (yr.hi - yr.lo) / ny;
      double wsum = 0, zsum = 0;
      for (std::size_t k = 0; k < n; ++k) {
        const double dx = (map.x[k] - gx) / (xr.hi - xr.lo), dy = (map.y[k] - gy) / (xr.hi - xr.lo);
        const double w = 1.0 / (dx * dx + dy * dy + 1e-12);
        wsum += w;
        zsum += w * map.z[k];
      }
      const double z = zsum / wsum;
      o << "<rect x=\"" << px(f.left + i * pw / nx) << "\" y=\"" << px(f.top + (ny - 1 - j) * ph / ny) << "\" width=\""
        << px(pw / nx + 0.6) << "\" height=\"" << px(ph / ny + 0.6) << "\" fill=\""
        << colormap((z - zr.lo) / (zr.hi - zr.lo)) << "\"/>";
    }
  }
  o << "</g>";
  o << x_axis(sx, nice_ticks(xr.lo, xr.hi, 8), f.bottom, 0, true, map.x_label, (f.left + f.right) / 2, height - 8);
  o << y_axis(sy, nice_ticks(yr.lo, yr.hi, 6), f.left, 0, map.y_label, 16);
  o << "<g class=\"series\">";
  for (std::size_t l = 0; l < map.lines.size(); ++l) {
    std::vector<double> lx, ly;
    for (std::size_t k : map.lines[l])
      if (k < n) {
        lx.push_back(map.x[k]);
        ly.push_back(map.y[k]);
      }
    const std::string name = l < map.line_labels.size() ? map.line_labels[l] : "line " + std::to_string(l + 1);
    o << "<path class=\"data\" data-series=\"" << xml_escape(name) << "\" data-points=\"" << lx.size() << "\" d=\""
      << line_path_d(lx, ly, sx, sy) << "\" fill=\"none\" stroke=\"#ffffff\" stroke-opacity=\"0.8\""
      << " stroke-width=\"1.2\"/>";
  }
  o << "</g><g class=\"stations\">";
  for (std::size_t k = 0; k < n; ++k)
    o << "<circle cx=\"" << px(sx(map.x[k])) << "\" cy=\"" << px(sy(map.y[k])) << "\" r=\"3.2\" fill=\""
      << colormap((map.z[k] - zr.lo) / (zr.hi - zr.lo)) << "\" stroke=\"#222\" stroke-width=\"0.8\"><title>"
      << format_number(map.z[k], 4) << "</title></circle>";
  o << "</g><rect class=\"frame\" x=\"" << px(f.left) << "\" y=\"" << px(f.top) << "\" width=\"" << px(f.w())
    << "\" height=\"" << px(f.h()) << "\" fill=\"none\" stroke=\"#333\"/>";
  // Colour bar with its own scale.
  const double bx = f.right + 26, bw = 18;
  const Scale sz{zr.lo, zr.hi, f.bottom, f.top};
  o << "<g class=\"colorbar-fill\" shape-rendering=\"crispEdges\">";
  const int steps = 64;
  for (int s = 0; s < steps; ++s)
    o << "<rect x=\"" << px(bx) << "\" y=\"" << px(f.bottom - (s + 1) * ph / steps) << "\" width=\"" << px(bw)
      << "\" height=\"" << px(ph / steps + 0.6) << "\" fill=\"" << colormap((s + 0.5) / steps) << "\"/>";
  o << "</g>";
  o << y_axis(sz, zt, bx + bw, 0, "", 0, "axis colorbar", true);
  const double lx = bx + bw + 62, lcy = (f.top + f.bottom) / 2;
  o << "<text class=\"axis-label z\" x=\"" << px(lx) << "\" y=\"" << px(lcy) << "\" text-anchor=\"middle\""
    << " font-size=\"13\" transform=\"rotate(-90 " << px(lx) << ' ' << px(lcy) << ")\">" << xml_escape(map.z_label)
    << "</text>";
  o << "</svg>";
  return o.str();
}

namespace {

// One bar: two corners and where its value label goes.
struct Bar {
  double x0, y0, x1, y1;
  double label_x, label_y;
  const char* anchor;
};

// The chart's series as one path of bars each (NaN: no bar) with their value labels, placed by `place`
// (series, category, value) -> Bar.
template <typename Place>
std::string bar_series(const BarChart& chart, const Place& place) {
  std::ostringstream o;
  o << "<g class=\"series\">";
  for (std::size_t i = 0; i < chart.series.size(); ++i) {
    const auto& s = chart.series[i];
    std::string d;
    std::ostringstream labels;
    std::size_t count = 0;
    for (std::size_t c = 0; c < chart.categories.size() && c < s.values.size(); ++c) {
      if (!std::isfinite(s.values[c])) continue;
      const Bar b = place(i, c, s.values[c]);
      if (!d.empty()) d += ' ';
      d += 'M' + format_fixed(b.x0, 2) + ' ' + format_fixed(b.y0, 2) + " H" + format_fixed(b.x1, 2) + " V" +
           format_fixed(b.y1, 2) + " H" + format_fixed(b.x0, 2) + " Z";
      labels << "<text class=\"value-label\" x=\"" << px(b.label_x) << "\" y=\"" << px(b.label_y) << "\" text-anchor=\""
             << b.anchor << "\" font-size=\"10\">" << format_number(s.values[c], 3) << "</text>";
      ++count;
    }
    o << "<path class=\"data\" data-series=\"" << xml_escape(s.label) << "\" data-points=\"" << count << "\" d=\"" << d
      << "\" fill=\"" << (s.color.empty() ? palette(i) : s.color) << "\"/>" << labels.str();
  }
  o << "</g>";
  return o.str();
}

// Bars along x, one row per category: the label column as wide as the longest label (at a generous
// character width, so the browser's font never runs into the axis), a value label after each bar.
std::string render_horizontal(const BarChart& chart) {
  double lo = 0, hi = 0;
  for (const auto& s : chart.series) extent(s.values, lo, hi);
  const Range d = chart.y_range ? *chart.y_range : widen(lo, hi);
  const Ticks xt = nice_ticks(d.lo, d.hi);
  const Range xr = chart.y_range ? *chart.y_range : Range{xt.values.front(), xt.values.back()};
  // A legend only for several series (one series is what the title and axis say).
  std::vector<LegendItem> items;
  for (std::size_t i = 0; chart.series.size() > 1 && i < chart.series.size(); ++i)
    items.push_back(
        {chart.series[i].label, chart.series[i].color.empty() ? palette(i) : chart.series[i].color, Style::line, true});
  std::size_t longest = 0;
  for (const auto& c : chart.categories) longest = std::max(longest, display_chars(c));
  const double label_w = std::min(chart.width * 0.5, kLabelCharWidth * static_cast<double>(longest) + 12);
  const int rows = legend_rows(items, 16, chart.width - 16);
  const double row_h = std::max(22.0, 10.0 + 12.0 * static_cast<double>(chart.series.size()));
  // The categories' title sits over the label column, under the title and the legend.
  const double top = kTitleHeight + rows * kLegendRow + (chart.x_label.empty() ? 8 : 26);
  const Frame f{16 + label_w, top, chart.width - 40, top + row_h * static_cast<double>(chart.categories.size())};
  const double height = f.bottom + 46;
  const Scale sx{xr.lo, xr.hi, f.left, f.right};
  const double bar_h = row_h * 0.7 / static_cast<double>(std::max<std::size_t>(1, chart.series.size()));

  std::ostringstream o;
  o << open_svg("bar", chart.width, height, chart.title);
  o << legend(items, 16, chart.width - 16, kTitleHeight);
  o << x_axis(sx, xt, f.bottom, f.top, true, chart.y_label, (f.left + f.right) / 2, height - 10);
  o << "<g class=\"axis y categorical\">";
  for (std::size_t c = 0; c < chart.categories.size(); ++c) {
    const double cy = f.top + (static_cast<double>(c) + 0.5) * row_h;
    o << "<line class=\"tick\" x1=\"" << px(f.left - 5) << "\" y1=\"" << px(cy) << "\" x2=\"" << px(f.left)
      << "\" y2=\"" << px(cy) << "\" stroke=\"#333\"/>";
    o << "<text class=\"tick-label\" x=\"" << px(f.left - 8) << "\" y=\"" << px(cy + 4) << "\" text-anchor=\"end\">"
      << xml_escape(chart.categories[c]) << "</text>";
  }
  const double zero = sx(std::clamp(0.0, xr.lo, xr.hi));
  o << "<line class=\"axis-line\" x1=\"" << px(zero) << "\" y1=\"" << px(f.top) << "\" x2=\"" << px(zero) << "\" y2=\""
    << px(f.bottom) << "\" stroke=\"#333\"/></g>";
  if (!chart.x_label.empty())
    o << "<text class=\"axis-label y\" x=\"16\" y=\"" << px(f.top - 8) << "\" font-size=\"13\">"
      << xml_escape(chart.x_label) << "</text>";
  o << bar_series(chart, [&](std::size_t i, std::size_t c, double v) {
    const double y0 = f.top + static_cast<double>(c) * row_h + row_h * 0.15 + static_cast<double>(i) * bar_h;
    const double end = sx(std::clamp(v, xr.lo, xr.hi));
    return Bar{
        zero, y0, end, y0 + bar_h * 0.92, end + (v >= 0 ? 4 : -4), y0 + bar_h * 0.46 + 3.5, v >= 0 ? "start" : "end"};
  });
  o << "<rect class=\"frame\" x=\"" << px(f.left) << "\" y=\"" << px(f.top) << "\" width=\"" << px(f.w())
    << "\" height=\"" << px(f.h()) << "\" fill=\"none\" stroke=\"#333\"/></svg>";
  return o.str();
}

}  // namespace

std::string render(const BarChart& chart) {
  if (chart.horizontal) return render_horizontal(chart);
  double lo = 0, hi = 0;
  for (const auto& s : chart.series) extent(s.values, lo, hi);
  Ticks yt;
  Range yr;
  if (chart.y_range) {
    yr = *chart.y_range;
    yt = nice_ticks(yr.lo, yr.hi);
  } else {
    const Range d = widen(lo, hi);
    yt = nice_ticks(d.lo, d.hi);
    yr = {yt.values.front(), yt.values.back()};
  }
  std::vector<LegendItem> items;
  for (std::size_t i = 0; i < chart.series.size(); ++i)
    items.push_back(
        {chart.series[i].label, chart.series[i].color.empty() ? palette(i) : chart.series[i].color, Style::line, true});
  const int rows = legend_rows(items, 70, chart.width - 16);
  const Frame f{72, kTitleHeight + rows * kLegendRow + 8, chart.width - 18, chart.height - 46};
  const Scale sy{yr.lo, yr.hi, f.bottom, f.top};
  const std::size_t nc = std::max<std::size_t>(1, chart.categories.size());
  const double group_w = f.w() / static_cast<double>(nc);
  const double bar_w = group_w * 0.7 / static_cast<double>(std::max<std::size_t>(1, chart.series.size()));

  std::ostringstream o;
  o << open_svg("bar", chart.width, chart.height, chart.title);
  o << legend(items, f.left, chart.width - 16, kTitleHeight);
  o << y_axis(sy, yt, f.left, f.right, chart.y_label, 16);
  o << "<g class=\"axis x categorical\">";
  for (std::size_t c = 0; c < chart.categories.size(); ++c) {
    const double cxp = f.left + (static_cast<double>(c) + 0.5) * group_w;
    o << "<line class=\"tick\" x1=\"" << px(cxp) << "\" y1=\"" << px(f.bottom) << "\" x2=\"" << px(cxp) << "\" y2=\""
      << px(f.bottom + 5) << "\" stroke=\"#333\"/>";
    o << "<text class=\"tick-label\" x=\"" << px(cxp) << "\" y=\"" << px(f.bottom + 18) << "\" text-anchor=\"middle\">"
      << xml_escape(chart.categories[c]) << "</text>";
  }
  o << "<line class=\"axis-line\" x1=\"" << px(f.left) << "\" y1=\"" << px(sy(std::clamp(0.0, yr.lo, yr.hi)))
    << "\" x2=\"" << px(f.right) << "\" y2=\"" << px(sy(std::clamp(0.0, yr.lo, yr.hi))) << "\" stroke=\"#333\"/>";
  o << "</g>";
  if (!chart.x_label.empty())
    o << "<text class=\"axis-label x\" x=\"" << px((f.left + f.right) / 2) << "\" y=\"" << px(chart.height - 8)
      << "\" text-anchor=\"middle\" font-size=\"13\">" << xml_escape(chart.x_label) << "</text>";
  const double base = sy(std::clamp(0.0, yr.lo, yr.hi));
  o << bar_series(chart, [&](std::size_t i, std::size_t c, double v) {
    const double x0 = f.left + static_cast<double>(c) * group_w + group_w * 0.15 + static_cast<double>(i) * bar_w;
    const double top = sy(std::clamp(v, yr.lo, yr.hi));
    return Bar{x0, base, x0 + bar_w * 0.92, top, x0 + bar_w * 0.46, v >= 0 ? top - 4 : top + 12, "middle"};
  });
  o << "<rect class=\"frame\" x=\"" << px(f.left) << "\" y=\"" << px(f.top) << "\" width=\"" << px(f.w())
    << "\" height=\"" << px(f.h()) << "\" fill=\"none\" stroke=\"#333\"/></svg>";
  return o.str();
}

}  // namespace guideway::report

namespace guideway::report {

std::string render(const VectorField& field) {
  const std::size_t n = std::min({field.x.size(), field.y.size(), field.u.size(), field.v.size()});
  if (n == 0) throw std::invalid_argument("vector field: no points");
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
  extent(field.x, xlo, xhi);
  extent(field.y, ylo, yhi);
  Range xr = widen(xlo, xhi), yr = widen(ylo, yhi);
  // Room around the points for the arrows at the edges.
  const double mx = 0.12 * (xr.hi - xr.lo), my = 0.12 * (yr.hi - yr.lo);
  xr = {xr.lo - mx, xr.hi + mx};
  yr = {yr.lo - my, yr.hi + my};
  double longest = 0;
  for (std::size_t k = 0; k < n; ++k) longest = std::max(longest, std::hypot(field.u[k], field.v[k]));
  bool colored = field.w.size() >= n;
  double wlo = 0, whi = 0;
  if (colored) {
    wlo = std::numeric_limits<double>::infinity();
    whi = -wlo;
    extent(field.w, wlo, whi);
    // Symmetric about 0 and out to the ticks, so the colour bar's ends are labelled.
    const double h = std::max(std::abs(wlo), std::abs(whi));
    if (!(h > 0)) {
      colored = false;
    } else {
      const Ticks t = nice_ticks(-h, h, 4);
      whi = std::max(-t.values.front(), t.values.back());
      wlo = -whi;
    }
  }

  const double left = 70, bar_w = colored ? 96 : 16;
  double pw = field.width - left - bar_w;
  double ph = pw * (yr.hi - yr.lo) / (xr.hi - xr.lo);
  if (ph > 360) {
    pw *= 360 / ph;
    ph = 360;
  }
  const double legend_h = kLegendRow + 4;
  const Frame f{left, kTitleHeight + legend_h + 6, left + pw, kTitleHeight + legend_h + 6 + ph};
  const double height = f.bottom + 52;
  const Scale sx{xr.lo, xr.hi, f.left, f.right};
  const Scale sy{yr.lo, yr.hi, f.bottom, f.top};
  // The longest arrow spans about a sixth of the face.
  const double cell_px = std::min(pw, ph) / 6.0;
  const double step = longest > 0 ? nice_ceil(longest) : 1.0;
  const double px_per_unit = cell_px / step;

  std::ostringstream o;
  o << open_svg("vectors", field.width, height, field.title);
  // Legend: the scale arrow.
  {
    const double y = kTitleHeight + 12;
    const double x0 = f.left, x1 = f.left + cell_px;
    const std::string label = "arrow = " + format_number(step, 3) + " " + field.vector_unit;
    o << "<g class=\"legend\"><g class=\"legend-item\"><path d=\"M" << px(x0) << ' ' << px(y - 4) << " L" << px(x1) << ' '
      << px(y - 4) << " M" << px(x1 - 6) << ' ' << px(y - 8) << " L" << px(x1) << ' ' << px(y - 4) << " L" << px(x1 - 6)
      << ' ' << px(y) << "\" stroke=\"#333\" stroke-width=\"1.6\" fill=\"none\"/><text x=\"" << px(x1 + 8) << "\" y=\""
      << px(y) << "\">" << xml_escape(label) << "</text></g></g>";
  }
  o << x_axis(sx, nice_ticks(xr.lo, xr.hi, 6), f.bottom, f.top, true, field.x_label, (f.left + f.right) / 2, height - 8);
  o << y_axis(sy, nice_ticks(yr.lo, yr.hi, 6), f.left, f.right, field.y_label, 16);
  std::string d;
  std::ostringstream arrows;
  for (std::size_t k = 0; k < n; ++k) {
    const double x0 = sx(field.x[k]), y0 = sy(field.y[k]);
    const double dx = field.u[k] * px_per_unit, dy = -field.v[k] * px_per_unit;
    const double len = std::hypot(dx, dy);
    std::string a = "M" + format_fixed(x0, 2) + ' ' + format_fixed(y0, 2) + " L" + format_fixed(x0 + dx, 2) + ' ' +
                    format_fixed(y0 + dy, 2);
    if (len > 4) {
      const double ux = dx / len, uy = dy / len, hl = std::min(6.0, 0.4 * len);
      a += " M" + format_fixed(x0 + dx - hl * ux - 0.5 * hl * uy, 2) + ' ' +
           format_fixed(y0 + dy - hl * uy + 0.5 * hl * ux, 2) + " L" + format_fixed(x0 + dx, 2) + ' ' +
           format_fixed(y0 + dy, 2) + " L" + format_fixed(x0 + dx - hl * ux + 0.5 * hl * uy, 2) + ' ' +
           format_fixed(y0 + dy - hl * uy - 0.5 * hl * ux, 2);
    }
    const std::string color = colored ? colormap((field.w[k] - wlo) / (whi - wlo)) : palette(0);
    arrows << "<path class=\"arrow\" d=\"" << a << "\" stroke=\"" << color << "\" stroke-width=\"1.5\" fill=\"none\"/>";
    arrows << "<circle cx=\"" << px(x0) << "\" cy=\"" << px(y0) << "\" r=\"1.6\" fill=\"#333\"/>";
    d += a + ' ';
  }
  // The data path (all arrows) for tools and tests; drawn transparent under the coloured arrows.
  o << "<g class=\"series\"><path class=\"data\" data-series=\"error vectors\" data-points=\"" << n << "\" d=\"" << d
    << "\" stroke=\"none\" fill=\"none\"/>" << arrows.str() << "</g>";
  o << "<rect class=\"frame\" x=\"" << px(f.left) << "\" y=\"" << px(f.top) << "\" width=\"" << px(f.w())
    << "\" height=\"" << px(f.h()) << "\" fill=\"none\" stroke=\"#333\"/>";
  if (colored) {
    const double bx = f.right + 18, bw = 14;
    o << "<g class=\"axis colorbar\">";
    const int cells = 40;
    for (int i = 0; i < cells; ++i)
      o << "<rect x=\"" << px(bx) << "\" y=\"" << px(f.bottom - (i + 1) * ph / cells) << "\" width=\"" << px(bw)
        << "\" height=\"" << px(ph / cells + 0.6) << "\" fill=\"" << colormap((i + 0.5) / cells) << "\"/>";
    const Ticks wt = nice_ticks(wlo, whi, 4);
    const Scale sw{wlo, whi, f.bottom, f.top};  // the ends of the colour scale are the field's largest |w|
    for (double v : wt.values) {
      if (v < wlo - 1e-9 * (whi - wlo) || v > whi + 1e-9 * (whi - wlo)) continue;
      o << "<line class=\"tick\" x1=\"" << px(bx + bw) << "\" y1=\"" << px(sw(v)) << "\" x2=\"" << px(bx + bw + 4)
        << "\" y2=\"" << px(sw(v)) << "\" stroke=\"#333\"/><text class=\"tick-label\" x=\"" << px(bx + bw + 7) << "\" y=\""
        << px(sw(v) + 4) << "\">" << format_fixed(v, wt.decimals) << "</text>";
    }
    o << "</g>";
    const double cy = (f.top + f.bottom) / 2, lx = field.width - 8;
    o << "<text class=\"axis-label colorbar\" x=\"" << px(lx) << "\" y=\"" << px(cy) << "\" text-anchor=\"middle\""
      << " font-size=\"13\" transform=\"rotate(-90 " << px(lx) << ' ' << px(cy) << ")\">" << xml_escape(field.w_label)
      << "</text>";
  }
  o << "</svg>";
  return o.str();
}

}  // namespace guideway::report
