// report/: the SVG writer's building blocks (ticks, scales, number formatting, escaping), the structure of
// each plot kind, input recognition and the report's errors. The XML itself and the axis mapping are also
// checked from outside by report_svg_xml_test.py; the whole page in Chromium by report_chromium_test.py.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <tuple>

#include <nlohmann/json.hpp>

#include "formats/dbb_run.hpp"
#include "models/explain/explanation.hpp"
#include "report/html.hpp"
#include "report/report.hpp"
#include "report/svg.hpp"
#include "simulators/machine/dbb_runs.hpp"
#include "simulators/machine/machine.hpp"
#include "simulators/scenarios/scenarios.hpp"

using namespace guideway;
namespace fs = std::filesystem;

namespace {

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

// Tags balance (a cheap well-formedness check; the Python test uses a real XML parser).
bool tags_balance(const std::string& svg) {
  std::vector<std::string> stack;
  for (auto p = svg.find('<'); p != std::string::npos; p = svg.find('<', p + 1)) {
    const auto q = svg.find('>', p);
    if (q == std::string::npos) return false;
    const std::string tag = svg.substr(p + 1, q - p - 1);
    if (tag.empty() || tag[0] == '!' || tag[0] == '?') continue;
    const bool closing = tag[0] == '/';
    const bool self_closing = tag.back() == '/';
    const auto start = closing ? 1u : 0u;
    const std::string name = tag.substr(start, tag.find_first_of(" /", start) - start);
    if (self_closing) continue;
    if (!closing) {
      stack.push_back(name);
    } else {
      if (stack.empty() || stack.back() != name) return false;
      stack.pop_back();
    }
  }
  return stack.empty();
}

double mantissa(double step) { return step / std::pow(10.0, std::floor(std::log10(step) + 1e-9)); }

// The project's copy of the real data (tests/data: Moody 1955).
std::string data_dir() { return GUIDEWAY_TEST_DATA_DIR; }

fs::path temp_dir(const std::string& name) {
  const auto d = fs::temp_directory_path() / ("guideway_report_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

}  // namespace

TEST(ReportSvg, NiceTicksCoverTheRangeWithOneTwoFiveSteps) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> e(-6, 6), u(-1, 1);
  for (int i = 0; i < 2000; ++i) {
    const double scale = std::pow(10.0, e(rng));
    const double a = u(rng) * scale * 10, b = a + std::abs(u(rng)) * scale;
    const auto t = report::nice_ticks(a, b, 6);
    ASSERT_GE(t.values.size(), 2u);
    EXPECT_LE(t.values.front(), a + 1e-12 * std::abs(a));
    EXPECT_GE(t.values.back(), b - 1e-12 * std::abs(b));
    EXPECT_LE(t.values.size(), 14u) << a << " " << b;
    const double m = mantissa(t.step);
    EXPECT_TRUE(std::abs(m - 1) < 1e-9 || std::abs(m - 2) < 1e-9 || std::abs(m - 5) < 1e-9) << t.step;
    // Every tick prints distinctly with the stated decimals.
    for (std::size_t k = 1; k < t.values.size(); ++k)
      EXPECT_NE(guideway::format_fixed(t.values[k - 1], t.decimals), guideway::format_fixed(t.values[k], t.decimals));
  }
  EXPECT_EQ(report::nice_ticks(0, 0).values.size() >= 2, true);
  EXPECT_THROW((void)report::nice_ticks(0, NAN), std::invalid_argument);
}

TEST(ReportSvg, NiceCeilAndScale) {
  EXPECT_DOUBLE_EQ(report::nice_ceil(0.7), 1.0);
  EXPECT_DOUBLE_EQ(report::nice_ceil(1.0), 1.0);
  EXPECT_DOUBLE_EQ(report::nice_ceil(1.01), 2.0);
  EXPECT_DOUBLE_EQ(report::nice_ceil(3), 5.0);
  EXPECT_NEAR(report::nice_ceil(0.0031), 0.005, 1e-15);
  EXPECT_THROW((void)report::nice_ceil(0), std::invalid_argument);
  const report::Scale s{-2, 3, 400, 100};  // y up: data -2 at the bottom pixel 400
  EXPECT_DOUBLE_EQ(s(-2), 400);
  EXPECT_DOUBLE_EQ(s(3), 100);
  EXPECT_DOUBLE_EQ(s(0.5), 250);
}

TEST(ReportSvg, NumberFormattingAndEscaping) {
  EXPECT_EQ(guideway::format_fixed(-0.0001, 2), "0.00");
  EXPECT_EQ(guideway::format_fixed(-1.5, 1), "-1.5");
  EXPECT_EQ(guideway::format_number(0.0123456, 3), "0.0123");
  EXPECT_EQ(guideway::format_number(1234.6, 4), "1235");  // no exponent
  EXPECT_EQ(guideway::with_uncertainty(1.23456, 0.0123), "1.235 \u00b1 0.012");
  EXPECT_EQ(guideway::with_uncertainty(2.5, NAN, 5), "2.5000");
  EXPECT_EQ(guideway::with_uncertainty(2.2519e-7, 8.5e-10), "(2.2519 \u00b1 0.0085)e-7");
  EXPECT_EQ(report::xml_escape("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
}

TEST(ReportSvg, LinePlotStructure) {
  report::LinePlot p;
  p.title = "t <1>";
  p.x_label = "x / mm";
  p.y_label = "y / um";
  for (int s = 0; s < 3; ++s) {
    report::Series ser;
    ser.label = "s" + std::to_string(s);
    for (int i = 0; i < 50; ++i) {
      ser.x.push_back(i);
      ser.y.push_back(s * std::sin(i * 0.1) + (i == 20 ? NAN : 0.0));
    }
    ser.style = s == 2 ? report::Style::line_markers : report::Style::line;
    p.series.push_back(ser);
  }
  const auto svg = report::render(p);
  EXPECT_TRUE(tags_balance(svg));
  EXPECT_EQ(count(svg, "class=\"data\""), 3u);
  EXPECT_EQ(count(svg, "class=\"axis x\""), 1u);
  EXPECT_EQ(count(svg, "class=\"axis y\""), 1u);
  EXPECT_EQ(count(svg, "class=\"axis-label"), 2u);
  EXPECT_EQ(count(svg, "class=\"legend-item\""), 3u);
  EXPECT_NE(svg.find("t &lt;1&gt;"), std::string::npos);
  // The NaN at i = 20 breaks the line: a second move-to in each series path.
  const auto first = svg.find("data-series=\"s1\"");
  const auto d = svg.substr(svg.find(" d=\"", first), svg.find("\" fill", first) - svg.find(" d=\"", first));
  EXPECT_EQ(count(d, "M"), 2u);
}

TEST(ReportSvg, LongSeriesAreDecimatedKeepingExtremes) {
  report::LinePlot p;
  p.x_label = "x / mm";
  p.y_label = "y / um";
  report::Series s;
  s.label = "long";
  for (int i = 0; i < 100000; ++i) {
    s.x.push_back(i);
    s.y.push_back(i == 51234 ? 50.0 : std::sin(i * 0.01));
  }
  p.series = {s};
  const auto svg = report::render(p);
  EXPECT_LT(svg.size(), 200000u);
  const auto at = svg.find("data-points=\"");
  ASSERT_NE(at, std::string::npos);
  EXPECT_LT(std::stoul(svg.substr(at + 13)), 4000u);
  // The spike survives: the y axis reaches 50 and a point sits at the top tick's pixel row.
  EXPECT_NE(svg.find(">50</text>"), std::string::npos);
}

TEST(ReportSvg, PolarScaleIsTheSmallestFittingOneTwoFiveValue) {
  for (double amp : {0.03, 0.7, 1.0, 3.9, 4.0, 17.0, 250.0}) {
    report::PolarPlot p;
    p.divisions = 4;  // given: the scale alone is chosen
    report::PolarSeries s;
    for (int i = 0; i < 360; ++i) {
      s.angle_rad.push_back(i * std::numbers::pi / 180);
      s.deviation_um.push_back(amp * std::cos(2 * i * std::numbers::pi / 180));
    }
    p.series = {s};
    const double per = report::polar_um_per_div(p);
    EXPECT_LE(amp, (p.divisions - 0.2) * per * (1 + 1e-12)) << amp;
    const double m = mantissa(per);
    const double smaller = per * (std::abs(m - 5) < 1e-9 ? 0.4 : 0.5);
    EXPECT_GT(amp, (p.divisions - 0.2) * smaller) << amp;
    const auto svg = report::render(p);
    EXPECT_TRUE(tags_balance(svg));
    EXPECT_EQ(count(svg, "class=\"ring\""), 2u * p.divisions);
    EXPECT_NE(svg.find(guideway::format_number(per, 3) + " \u00b5m/div"), std::string::npos);
  }
}

TEST(ReportSvg, PolarScaleFillsThePlot) {
  // The deviation about the least-squares circle: its largest value reaches 64 % to 97 % of the outer
  // ring whatever its size, with 3 to 5 divisions of a 1-2-5 step.
  for (double amp = 0.011; amp < 500; amp *= 1.37) {
    report::PolarPlot p;
    report::PolarSeries s;
    for (int i = 0; i < 360; ++i) {
      s.angle_rad.push_back(i * std::numbers::pi / 180);
      s.deviation_um.push_back(amp * std::sin(3 * i * std::numbers::pi / 180));
    }
    p.series = {s};
    const report::PolarScale scale = report::polar_scale(p);
    const double m = mantissa(scale.um_per_div);
    EXPECT_TRUE(std::abs(m - 1) < 1e-9 || std::abs(m - 2) < 1e-9 || std::abs(m - 5) < 1e-9) << scale.um_per_div;
    EXPECT_GE(scale.divisions, 3);
    EXPECT_LE(scale.divisions, 5);
    const double reach = amp / (scale.divisions * scale.um_per_div);
    EXPECT_GE(reach, 0.63) << amp;
    EXPECT_LE(reach, 0.975) << amp;
    const std::string svg = report::render(p);
    EXPECT_EQ(count(svg, "class=\"ring\""), 2u * static_cast<unsigned>(scale.divisions));
    // Ring values: every ring's when the rings are far enough apart for the text, else every other (the
    // bold ring's always), never more than seven, so that no label runs into the next.
    const std::size_t labels = count(svg, "ring-label");
    EXPECT_GE(labels, 5u) << amp;
    EXPECT_LE(labels, 7u) << amp;
  }
}

TEST(ReportSvg, HeightMapAndBarsAndPanels) {
  report::HeightMap h;
  h.x_label = "x / mm";
  h.y_label = "y / mm";
  h.z_label = "height / um";
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 3; ++j) {
      h.x.push_back(i * 100.0);
      h.y.push_back(j * 100.0);
      h.z.push_back(i * 0.5 - j);
    }
  h.lines = {{0, 1, 2}, {0, 4, 8, 12}};
  const auto hs = report::render(h);
  EXPECT_TRUE(tags_balance(hs));
  EXPECT_EQ(count(hs, "class=\"data\""), 2u);
  EXPECT_EQ(count(hs, "class=\"axis colorbar\""), 1u);
  EXPECT_EQ(count(hs, "<circle"), 15u);

  report::BarChart b;
  b.y_label = "rms / um";
  b.categories = {"a", "b", "c"};
  b.series = {{"in", {1.0, 0.5, 0.25}, ""}, {"out", {1.2, NAN, 0.3}, ""}};
  const auto bs = report::render(b);
  EXPECT_TRUE(tags_balance(bs));
  EXPECT_EQ(count(bs, "class=\"data\""), 2u);
  EXPECT_EQ(count(bs, "data-points=\"2\""), 1u);  // the NaN bar is left out
  // Horizontal: a row per category, its label right-aligned left of the frame, the value axis at the bottom.
  b.horizontal = true;
  b.categories = {"Y straightness along Z", "b", "a rather long category label, still on its own row"};
  const auto hb = report::render(b);
  EXPECT_TRUE(tags_balance(hb));
  EXPECT_EQ(count(hb, "class=\"axis y categorical\""), 1u);
  EXPECT_EQ(count(hb, "class=\"axis x\""), 1u);
  EXPECT_EQ(count(hb, "text-anchor=\"end\">"), 3u);
  EXPECT_EQ(count(hb, "data-points=\"2\""), 1u);

  report::StackedPanels sp;
  sp.x_label = "x / mm";
  sp.y_unit = "um";
  for (const char* n : {"s", "a1", "d1"})
    sp.panels.push_back({n, {0, 1, 2, 3}, {0, 1, 0, 1}, "", report::Style::line, 1});
  const auto ps = report::render(sp);
  EXPECT_TRUE(tags_balance(ps));
  EXPECT_EQ(count(ps, "class=\"panel\""), 3u);
  EXPECT_EQ(count(ps, "class=\"axis y\""), 3u);
  EXPECT_EQ(count(ps, "class=\"axis-label x\""), 1u);  // only under the bottom panel
}

TEST(Report, RecognisesInputsAndRendersSections) {
  const auto dir = temp_dir("render");
  const guideway::simulators::machine::Machine machine(guideway::simulators::machine::default_machine_config());
  guideway::simulators::machine::DbbCircleSpec spec;
  spec.radius_m = 0.1;
  std::vector<std::string> inputs;
  for (auto d : {guideway::formats::DbbDirection::ccw, guideway::formats::DbbDirection::cw}) {
    spec.direction = d;
    const auto path = (dir / (d == guideway::formats::DbbDirection::ccw ? "ccw.csv" : "cw.csv")).string();
    guideway::formats::write_dbb_run(guideway::simulators::machine::simulate_dbb_run(machine, spec, path), path);
    inputs.push_back(path);
  }
  inputs.push_back(data_dir() + "/moody1955");
  inputs.push_back(std::string(GUIDEWAY_SOURCE_DIR) + "/tests/report/report_explain_example.json");
  EXPECT_EQ(report::detect_input(inputs[0]), report::InputKind::dbb_run);
  EXPECT_EQ(report::detect_input(inputs[2]), report::InputKind::union_jack);
  EXPECT_EQ(report::detect_input(inputs[3]), report::InputKind::explain);

  const auto html = report::render_report(inputs);
  EXPECT_EQ(count(html, "<section class=\"analysis\""), 3u);         // both runs in one DBB section
  EXPECT_EQ(count(html, "class=\"plot\" data-plot=\"polar\""), 1u);  // one set-up, CW and CCW overlaid
  EXPECT_NE(html.find("circular hysteresis H"), std::string::npos);
  EXPECT_NE(html.find("backlash X"), std::string::npos);
  // Values held at a searched or assumed value (a spike's decay) are one line under the diagnostics,
  // not rows without a u among the measured ones.
  const auto held = html.find("Held at a searched or assumed value (no u): ");
  ASSERT_NE(held, std::string::npos);
  EXPECT_LT(html.find("reversal spike decay X"), html.find("<", held + 1)) << "the decay is in that line";
  EXPECT_GT(html.find("reversal spike decay X"), html.find("Ballbar diagnostics</caption>"));
  EXPECT_GT(html.find("reversal spike decay X"), held);
  EXPECT_EQ(count(html, "class=\"plot\" data-plot=\"heightmap\""), 1u);
  // The DBB section's ranking ("what to fix first", beside the polar plot) and the explanation's RMS
  // after each finding (the example explanation carries no contributions: no ranking of its findings).
  EXPECT_EQ(count(html, "class=\"plot\" data-plot=\"bar\""), 2u);
  EXPECT_NE(html.find("What to fix first"), std::string::npos);
  EXPECT_NE(html.find("<div class=\"side-by-side\">"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  fs::remove_all(dir);
}

// Runs traced with the compensation loaded whose reversal spikes are negative (an axis turning back early: the
// tables' backlash step, docs/compensation.md) get a note that says so, not the stiction a spike otherwise means;
// the same runs before compensation, and a positive spike after, get none.
TEST(Report, NegativeSpikesAfterCompensationAreSaidToBeTheTablesStep) {
  const auto dir = temp_dir("step_spikes");
  const auto render = [&](double spike_m, const char* stage) {
    guideway::simulators::machine::MachineConfig cfg;
    cfg.dbb.noise_m = 0.1e-6;
    cfg.axis[1].reversal_spike_m = spike_m;
    const guideway::simulators::machine::Machine machine(cfg);
    std::vector<std::string> paths;
    for (const auto d : {guideway::formats::DbbDirection::ccw, guideway::formats::DbbDirection::cw}) {
      guideway::simulators::machine::DbbCircleSpec spec;
      spec.radius_m = 0.1;
      spec.direction = d;
      const auto path =
          (dir / (std::string(stage) + (d == guideway::formats::DbbDirection::ccw ? "_ccw" : "_cw") + ".csv")).string();
      auto run = guideway::simulators::machine::simulate_dbb_run(machine, spec, path);
      run.metadata["compensation"] = stage;
      guideway::formats::write_dbb_run(run, path);
      paths.push_back(path);
    }
    return report::render_report(paths);
  };
  const std::string note = "the tables&#39; backlash step";
  EXPECT_NE(render(-1.5e-6, "after").find(note), std::string::npos);
  EXPECT_EQ(render(-1.5e-6, "before").find(note), std::string::npos);
  EXPECT_EQ(render(1.5e-6, "after").find(note), std::string::npos);
  fs::remove_all(dir);
}

// Lai's three patterns (the demo's session) give no ballbar diagnostics: the section says why once and
// shows no table of only a header, no "0 points" fit; the ranking is in words, as horizontal bars, and
// every polar plot is of the deviation about the run's least-squares circle. Runs of a compensation check
// come out before first, whatever order the files are given in (a glob puts after_* first).
TEST(Report, DbbSectionShowsNoEmptyPartsAndBeforeComesFirst) {
  const auto dir = temp_dir("lai_patterns");
  const guideway::simulators::machine::Machine machine(guideway::simulators::machine::default_machine_config());
  std::vector<std::string> after, before;
  int k = 0;
  for (const auto& [r_m, h_m, d] : {std::tuple{0.095, 0.031225, guideway::formats::DbbDirection::cw},
                                    std::tuple{0.095, 0.031225, guideway::formats::DbbDirection::ccw},
                                    std::tuple{0.1, 0.0, guideway::formats::DbbDirection::ccw}}) {
    guideway::simulators::machine::DbbCircleSpec spec;
    spec.radius_m = r_m;
    spec.height_m = h_m;
    spec.direction = d;
    spec.feed_m_per_s = 5.0 / 60;
    spec.sample_rate_hz = 100;  // about 2 samples a degree: what the report shows, at a fifth of EXPLAIN's cost
    ++k;
    for (const char* stage : {"after", "before"}) {
      const auto path = (dir / (std::string(stage) + "_" + std::to_string(k) + ".csv")).string();
      auto run = guideway::simulators::machine::simulate_dbb_run(machine, spec, path);
      run.metadata["compensation"] = stage;
      guideway::formats::write_dbb_run(run, path);
      (stage[0] == 'a' ? after : before).push_back(path);
    }
  }
  std::vector<std::string> inputs = after;
  inputs.insert(inputs.end(), before.begin(), before.end());
  const auto html = report::render_report(inputs);
  EXPECT_LT(html.find("3 runs, before compensation"), html.find("3 runs, after compensation"));
  EXPECT_LT(html.find("before_1.csv"), html.find("after_1.csv"));
  EXPECT_EQ(html.find("Ballbar diagnostics</caption>"), std::string::npos) << "a diagnostics table without rows";
  EXPECT_EQ(html.find(" 0 points"), std::string::npos);
  EXPECT_EQ(html.find("condition number"), std::string::npos);
  EXPECT_NE(html.find("no ballbar diagnostics: they need an in-plane"), std::string::npos);
  EXPECT_NE(html.find(">Y straightness along Z<"), std::string::npos);  // a category of the ranking
  EXPECT_EQ(html.find("y_straightness_in_z"), std::string::npos);
  EXPECT_EQ(count(html, "class=\"axis y categorical\""), 2u);       // horizontal bars, before and after
  EXPECT_EQ(count(html, "(bold ring: least-squares circle)"), 4u);  // two set-ups, twice
  EXPECT_NE(html.find("mean radius 94.9"), std::string::npos);      // the circle's own radius, stated
  fs::remove_all(dir);
}

// The residual before and after each finding (issue 9): the engine keeps one residual per step (base, then
// base + findings 1..k), the JSON carries them on one abscissa, and the report draws one panel per step.
TEST(Report, ExplanationDrawsTheResidualAfterEachFinding) {
  const simulators::scenarios::ScenarioResult sc = simulators::scenarios::run_scenario("dbb_backlash");
  const models::explain::Report& rep = sc.report;
  ASSERT_GE(rep.findings.size(), 1u) << sc.failure;
  ASSERT_EQ(rep.curve_steps.size(), rep.findings.size() + 1);
  ASSERT_FALSE(rep.curve_runs.empty());
  const auto rms_of = [&](const models::explain::ResidualStep& st) {
    double s2 = 0;
    std::size_t n = 0;
    for (const auto& curve : st.residual_um) {
      EXPECT_EQ(curve.size(), rep.curve_x.size()) << st.label;
      for (double v : curve) {
        s2 += v * v;
        ++n;
      }
    }
    return std::sqrt(s2 / static_cast<double>(n));
  };
  // The curves are the fit's residuals resampled on one grid: their rms is the step's rms.
  EXPECT_EQ(rep.curve_steps[0].label, "base model");
  EXPECT_NEAR(rms_of(rep.curve_steps[0]), rep.baseline.rms_um, 0.1 * rep.baseline.rms_um);
  for (std::size_t k = 0; k < rep.findings.size(); ++k) {
    EXPECT_EQ(rep.curve_steps[k + 1].label, "+ " + rep.findings[k].effect);
    EXPECT_NEAR(rms_of(rep.curve_steps[k + 1]), rep.findings[k].rms_um_after, 0.1 * rep.findings[k].rms_um_after);
  }
  // A concealed effect hardly changes the rms; the curves still differ by what the finding took out.
  double moved = 0;
  for (std::size_t i = 0; i < rep.curve_x.size(); ++i)
    moved = std::max(moved, std::abs(rep.curve_steps[1].residual_um[0][i] - rep.curve_steps[0].residual_um[0][i]));
  EXPECT_GT(moved, 0.2);  // um: the 0.5 um backlash steps

  nlohmann::json j = results::to_json(models::explain::explanation_of(rep));
  const auto& r = j.at("residuals");
  ASSERT_EQ(r.at("steps").size(), rep.findings.size() + 1);
  EXPECT_EQ(r.at("runs").size(), rep.curve_runs.size());
  for (const auto& st : r.at("steps"))
    for (const auto& curve : st.at("residual_um")) {
      ASSERT_EQ(curve.size(), r.at("x").size());
      for (const auto& v : curve) EXPECT_NEAR(v.get<double>() * 1e4, std::round(v.get<double>() * 1e4), 1e-6);
    }

  const auto dir = temp_dir("explain_steps");
  const auto path = (dir / "explain.json").string();
  std::ofstream(path) << j.dump();
  const auto html = report::render_report({path});
  EXPECT_EQ(count(html, "class=\"plot\" data-plot=\"line\""), rep.findings.size() + 1);
  EXPECT_NE(html.find(">Residual of the base model: rms "), std::string::npos);
  EXPECT_NE(html.find(">Residual after + " + rep.findings[0].effect + " (finding 1): rms "), std::string::npos);
  // Every run in every panel.
  EXPECT_EQ(count(html, "data-series=\"" + rep.curve_runs[0] + "\""), rep.findings.size() + 1);

  // A step without a curve for every run is an error naming the file.
  j["residuals"]["steps"][1]["residual_um"].erase(0);
  std::ofstream(path) << j.dump();
  try {
    (void)report::render_report({path});
    ADD_FAILURE() << "no error";
  } catch (const report::ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("explain.json: residuals: step '+ "), std::string::npos) << e.what();
  }
  // A field of another type than the protocol gives it (results::explanation_from_json): an error naming both.
  j["findings"][0]["p_value"] = "small";
  std::ofstream(path) << j.dump();
  try {
    (void)report::render_report({path});
    ADD_FAILURE() << "no error";
  } catch (const report::ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("explain.json: not an explanation: findings[0]: \"p_value\" is string"),
              std::string::npos)
        << e.what();
  }
  // An EXPLAIN that says why nothing was analysed (a daemon session without an explanation model).
  std::ofstream(path)
      << R"({"model":"straightness traverse","not_analysed":"too few stations","findings":[],"unexplained":true})";
  const auto na = report::render_report({path});
  EXPECT_NE(na.find("Not analysed: too few stations"), std::string::npos);
  EXPECT_EQ(count(na, "class=\"plot\""), 0u);
  fs::remove_all(dir);
}

TEST(Report, BadInputIsAnErrorNamingTheFileAndLine) {
  const auto dir = temp_dir("errors");
  const auto unknown = (dir / "mystery.csv").string();
  std::ofstream(unknown) << "a,b\n1,2\n";
  try {
    (void)report::render_report({unknown});
    FAIL() << "no error";
  } catch (const report::ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("mystery.csv: not a recognised input"), std::string::npos) << e.what();
  }
  const auto bad = (dir / "bad.csv").string();
  std::ofstream(bad) << "# format = guideway/dbb-run/1\n# radius_mm = 100\n# height_mm = 0\n# direction = ccw\n"
                        "# feed_mm_per_min = 1000\n# plane = xy\nt_s,angle_deg,dL_um\n0,0,1\n0.1,1,x\n";
  try {
    (void)report::render_report({bad});
    FAIL() << "no error";
  } catch (const report::ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:9"), std::string::npos) << e.what();
  }
  const auto json = (dir / "e.json").string();
  std::ofstream(json) << "{\"model\": \"dbb\"";
  EXPECT_THROW((void)report::render_report({json}), report::ReportError);
  EXPECT_THROW((void)report::render_report({(dir / "missing.csv").string()}), report::ReportError);
  EXPECT_THROW((void)report::render_report({}), report::ReportError);
  fs::remove_all(dir);
}
