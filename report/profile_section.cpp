// Profiles of a faced workpiece: the profile and its wavelet MRA (Mu 2012 Figure 7).
#include <algorithm>
#include <cmath>
#include <sstream>

#include "formats/profile_files.hpp"
#include "dsp/series.hpp"
#include "dsp/wavelet.hpp"
#include "report/html.hpp"
#include "report/sections.hpp"
#include "report/svg.hpp"

namespace guideway::report {

std::string profile_section(const std::string& path, const std::string& id, const ReportOptions& options,
                            const std::string& correlation_html) {
  formats::Profile p;
  try {
    auto all = formats::read_profiles(path);
    if (all.empty()) throw ReportError(path + ": no profile in the file");
    p = std::move(all.front());
  } catch (const formats::ProfileFileError& e) {
    throw ReportError(e.what());
  }
  const std::size_t n = std::min(p.x_m.size(), p.z_m.size());
  if (n < 8) throw ReportError(path + ": a profile needs at least 8 points for the wavelet analysis");
  std::vector<double> x_mm(n), z_um(n);
  for (std::size_t i = 0; i < n; ++i) {
    x_mm[i] = p.x_m[i] * 1e3;
    z_um[i] = p.z_m[i] * 1e6;
  }
  const auto invalid = static_cast<std::size_t>(std::count_if(z_um.begin(), z_um.end(), [](double z) { return std::isnan(z); }));
  if (invalid == n) throw ReportError(path + ": every point of the profile is invalid");
  // Bridged as the session bridges them, so the plot shows what the published figures came from.
  const std::vector<double> filled = dsp::fill_gaps_linear(z_um);

  const dsp::Wavelet wavelet(options.wavelet);
  const int level = std::min(options.wavelet_level, dsp::dwt_max_level(n, wavelet.filter_length()));
  if (level < 1) throw ReportError(path + ": the profile is too short for a wavelet decomposition");
  const auto comps = dsp::mra(filled, wavelet, dsp::Mode::symmetric, level);  // [A_J, D_J, ..., D_1]
  // a_j = A_J + D_J + ... + D_(j+1): the approximation at every level from one decomposition.
  std::vector<std::vector<double>> approx(static_cast<std::size_t>(level) + 1);
  approx[static_cast<std::size_t>(level)] = comps[0];
  for (int j = level - 1; j >= 1; --j) {
    auto a = approx[static_cast<std::size_t>(j) + 1];
    const auto& d = comps[static_cast<std::size_t>(level - j)];  // D_(j+1)
    for (std::size_t i = 0; i < n; ++i) a[i] += d[i];
    approx[static_cast<std::size_t>(j)] = std::move(a);
  }

  std::ostringstream body;
  body << "<p><code>" << html_escape(base_name(path)) << "</code>: " << n << " points over "
       << format_number(x_mm.back() - x_mm.front(), 4) << " mm";
  for (const char* key : {"feed_mm_per_min", "spindle_rpm"})
    if (auto v = p.meta(key)) body << ", " << html_escape(key) << " = " << html_escape(*v);
  body << "; wavelet " << html_escape(options.wavelet) << ", " << level << " levels (Mu 2012 use db1, 5 levels).</p>";
  if (invalid > 0)
    body << html_note(std::to_string(invalid) + " invalid point(s) bridged linearly for the wavelet transform.");

  LinePlot plot;
  plot.title = "Profile of the faced workpiece (" + base_name(path) + ")";
  plot.x_label = "radial position x / mm";
  plot.y_label = "height z / \u00b5m";
  plot.series = {Series{"measured profile", x_mm, z_um, palette(5), Style::line, 1.0},
                 Series{"a1 (low-frequency part s1)", x_mm, approx[1], palette(0), Style::line, 1.8}};
  body << html_figure(render(plot), "The measured profile and its first approximation a1, the low-frequency part "
                                    "Mu correlate with the simulated carriage errors.");

  StackedPanels a;
  a.title = "Approximations a1..a" + std::to_string(level) + " (" + options.wavelet + ")";
  a.x_label = "radial position x / mm";
  a.y_unit = "\u00b5m";
  a.panels.push_back(Series{"s", x_mm, z_um, palette(6), Style::line, 1.0});
  for (int j = 1; j <= level; ++j)
    a.panels.push_back(Series{"a" + std::to_string(j), x_mm, approx[static_cast<std::size_t>(j)], palette(0),
                              Style::line, 1.2});
  StackedPanels d;
  d.title = "Details d1..d" + std::to_string(level) + " (" + options.wavelet + ")";
  d.x_label = "radial position x / mm";
  d.y_unit = "\u00b5m";
  for (int j = 1; j <= level; ++j)
    d.panels.push_back(Series{"d" + std::to_string(j), x_mm, comps[static_cast<std::size_t>(level + 1 - j)],
                              palette(1), Style::line, 1.0});
  body << html_figure(render(a), "Multiresolution analysis (Mu 2012, Figure 7, left): the signal s and its "
                                 "approximations; each panel has its own height scale.");
  body << html_figure(render(d), "Multiresolution analysis (Mu 2012, Figure 7, right): the details; "
                                 "s = a" + std::to_string(level) + " + d" + std::to_string(level) + " + ... + d1.");
  if (!correlation_html.empty())
    body << correlation_html;
  else
    body << html_note(
        "The correlation with the simulated squareness and straightness before and after the wavelet step (Mu's "
        "Figures 8-9) needs the X carriage's straightness traverse (x_mm,pitch_arcsec) among the report's inputs.");
  return html_section("profile", id, "Workpiece profile and wavelet MRA: " + base_name(path), body.str());
}

}  // namespace guideway::report
