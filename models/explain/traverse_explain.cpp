#include "models/explain/traverse_explain.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"
#include "formats/dabam.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/traverse_terms.hpp"
#include "models/flatness/instruments.hpp"
#include "models/flatness/straightness.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain {

namespace {

std::string at_line(const std::string& source, std::size_t line) { return source + ":" + std::to_string(line) + ": "; }


// Checks that the readings of `p` are one step apart in one direction (its first step gives it).
void check_stations(const CsvTable& t, const std::vector<std::size_t>& lines, TraversePass& p) {
  if (p.x_m.size() < 2)
    throw CsvError(t.source + ": " + p.source + " has " + std::to_string(p.x_m.size()) +
                   " reading(s); a pass needs at least 2");
  p.direction = p.x_m[1] > p.x_m[0] ? 1 : -1;
  for (std::size_t i = 1; i < p.x_m.size(); ++i) {
    const double dx = (p.x_m[i] - p.x_m[i - 1]) * p.direction;
    if (std::abs(dx - p.step_m) > flatness::station_jitter_tolerance * p.step_m)
      throw CsvError(at_line(t.source, lines[i]) + "x_mm = " + shortest(p.x_m[i] * 1e3) + " is not one step (" +
                     shortest(p.step_m * 1e3) + " mm) " + (p.direction > 0 ? "after" : "before") +
                     " the previous station " + shortest(p.x_m[i - 1] * 1e3) +
                     " (a pass runs one way, a step at a time; a new pass needs a new number in the pass column)");
    if (!p.t_s.empty() && !(p.t_s[i] > p.t_s[i - 1]))
      throw CsvError(at_line(t.source, lines[i]) + "t_s = " + shortest(p.t_s[i]) + " does not increase");
  }
}

}  // namespace

std::vector<TraversePass> parse_traverse_passes(const std::string& text, const std::string& source, std::size_t file,
                                                const flatness::Autocollimator& ac) {
  const CsvTable t = parse_csv_table(text, source);
  const double step_mm = flatness::traverse_step_mm(t);
  const std::size_t cx = t.column("x_mm"), cp = t.column("pitch_arcsec");
  const auto cy = t.find_column("yaw_arcsec"), ct = t.find_column("t_s"), cpass = t.find_column("pass");
  std::vector<TraversePass> out;
  std::vector<std::vector<std::size_t>> lines;
  double pass_number = std::numeric_limits<double>::quiet_NaN();
  for (const auto& row : t.rows) {
    const double n = cpass ? flatness::traverse_pass(t, row, *cpass) : 1.0;
    if (out.empty() || n != pass_number) {
      for (const TraversePass& p : out)
        if (p.source == source + " pass " + shortest(n))
          throw CsvError(at_line(source, row.line) + "pass " + shortest(n) + " again after other passes");
      pass_number = n;
      TraversePass p;
      p.source = cpass ? source + " pass " + shortest(n) : source;
      p.file = file;
      p.step_m = step_mm * 1e-3;
      out.push_back(std::move(p));
      lines.emplace_back();
    }
    TraversePass& p = out.back();
    if (p.x_m.size() == flatness::traverse_max_readings)
      throw CsvError(at_line(source, row.line) + "more than " + std::to_string(flatness::traverse_max_readings) +
                     " readings in a pass (the straightness session's most)");
    p.x_m.push_back(flatness::traverse_x_mm(t, row, cx) * 1e-3);
    p.pitch_rad.push_back(flatness::traverse_angle_rad(t, row, cp));
    if (cy) p.yaw_rad.push_back(flatness::traverse_angle_rad(t, row, *cy));
    if (ct) p.t_s.push_back(flatness::traverse_time_s(t, row, *ct));
    lines.back().push_back(row.line);
  }
  if (out.empty()) throw CsvError(source + ": no readings");
  for (std::size_t k = 0; k < out.size(); ++k) check_stations(t, lines[k], out[k]);
  // One set-up: the file's readings within the instrument's range about their middle.
  std::vector<double> pitch, yaw;
  std::vector<std::size_t> all_lines;
  for (std::size_t k = 0; k < out.size(); ++k) {
    pitch.insert(pitch.end(), out[k].pitch_rad.begin(), out[k].pitch_rad.end());
    yaw.insert(yaw.end(), out[k].yaw_rad.begin(), out[k].yaw_rad.end());
    all_lines.insert(all_lines.end(), lines[k].begin(), lines[k].end());
  }
  flatness::check_instrument_range(pitch, ac, "pitch_arcsec", source, all_lines);
  if (cy) flatness::check_instrument_range(yaw, ac, "yaw_arcsec", source, all_lines);
  return out;
}

std::vector<TraversePass> read_traverse_passes(const std::string& path, std::size_t file,
                                               const flatness::Autocollimator& ac) {
  if (formats::is_dabam_path(path)) return {slope_profile_pass(flatness::read_angle_traverse(path, ac), file)};
  return parse_traverse_passes(read_text_file(path), path, file, ac);
}

std::vector<TraversePass> read_traverse_files(const std::vector<std::string>& paths,
                                              const std::function<flatness::Autocollimator(const std::string&)>& instrument_of) {
  std::vector<TraversePass> out;
  for (std::size_t f = 0; f < paths.size(); ++f) {
    const flatness::Autocollimator ac = instrument_of ? instrument_of(paths[f]) : flatness::default_instrument(paths[f]);
    for (TraversePass& p : read_traverse_passes(paths[f], f, ac)) out.push_back(std::move(p));
  }
  return out;
}

TraversePass slope_profile_pass(const flatness::AngleTraverse& traverse, std::size_t file) {
  TraversePass p;
  p.source = traverse.source;
  p.file = file;
  p.direction = 1;
  p.step_m = traverse.step_m;
  p.x_m = traverse.x_m;
  p.pitch_rad = traverse.pitch_rad;
  p.yaw_rad = traverse.yaw_rad;
  return p;
}

namespace {

struct Layout {
  double x0_m = 0.0, span_m = 0.0, step_m = 0.0;
  std::size_t files = 0;
  bool timed = true, both = false, yaw = true;
};

Layout layout_of(const std::vector<TraversePass>& passes) {
  if (passes.empty()) throw std::invalid_argument("explain: no traverse passes");
  Layout l;
  double lo = 1e300, hi = -1e300, step = 1e300;
  bool fwd = false, back = false;
  std::vector<std::size_t> per_file;
  for (const TraversePass& p : passes) {
    if (p.x_m.size() < 2 || p.pitch_rad.size() != p.x_m.size() || !(p.step_m > 0))
      throw std::invalid_argument(p.source + ": a pass needs 2 or more readings, one pitch each, and a positive step");
    if ((!p.yaw_rad.empty() && p.yaw_rad.size() != p.x_m.size()) || (!p.t_s.empty() && p.t_s.size() != p.x_m.size()))
      throw std::invalid_argument(p.source + ": yaw or times differ in number from the readings");
    for (double x : p.x_m) {
      lo = std::min(lo, x);
      hi = std::max(hi, x + p.step_m);
    }
    step = std::min(step, p.step_m);
    (p.direction > 0 ? fwd : back) = true;
    l.yaw = l.yaw && !p.yaw_rad.empty();
    l.timed = l.timed && !p.t_s.empty();
    if (per_file.size() <= p.file) per_file.resize(p.file + 1, 0);
    ++per_file[p.file];
  }
  // The engine decomposes a run into wavelet bands only from 32 samples (models/explain/locate.cpp), and
  // needs one such run at least: said here in a traverse's terms.
  std::size_t longest = 0;
  for (const TraversePass& p : passes) longest = std::max(longest, p.x_m.size());
  if (longest < 32)
    throw std::invalid_argument("explain: the longest pass has " + std::to_string(longest) +
                                " readings; EXPLAIN's structure tests need a pass of 32 readings or more (over " +
                                shortest(std::round((hi - lo) * 1e6) / 1e3) + " mm: a step of " +
                                shortest(std::floor((hi - lo) * 1e3 / 32 * 100) / 100) + " mm or less)");
  l.x0_m = lo;
  l.span_m = hi - lo;
  l.step_m = step;
  l.files = per_file.size();
  l.both = fwd && back;
  // In one pass per file, time is a line in x, which the base's slope holds.
  l.timed = l.timed && std::any_of(per_file.begin(), per_file.end(), [](std::size_t n) { return n >= 2; });
  return l;
}

// Mu's Eq. 12 chord form of order k: (p(x + s) - p(x)) / s for p = xi^k, xi = (x - x0) / span.
double chord(double x_m, double step_m, const Layout& l, int k) {
  const double xi = (x_m - l.x0_m) / l.span_m, sigma = step_m / l.span_m;
  return (std::pow(xi + sigma, k) - std::pow(xi, k)) / sigma;
}

// The identification's polynomial (order by BIC, N ln(RSS/N) + q ln N, up to 8 and fewer than the stations
// of a pass) through every pass at once, and an offset for each file after the first.
Block base_block(const std::vector<TraversePass>& passes, const Layout& l, const Eigen::VectorXd& y,
                 std::string& note) {
  const auto n = y.size();
  std::size_t fewest = passes.front().x_m.size();
  for (const TraversePass& p : passes) fewest = std::min(fewest, p.x_m.size());
  const int highest = std::clamp(static_cast<int>(fewest) - 2, 1, 8);
  const auto design = [&](int order) {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, order + static_cast<Eigen::Index>(l.files) - 1);
    Eigen::Index row = 0;
    for (const TraversePass& p : passes)
      for (double x : p.x_m) {
        for (int k = 1; k <= order; ++k) a(row, k - 1) = chord(x, p.step_m, l, k);
        if (p.file > 0) a(row, order + static_cast<Eigen::Index>(p.file) - 1) = 1.0;
        ++row;
      }
    return a;
  };
  const double dn = static_cast<double>(n);
  int best = 1;
  double best_bic = std::numeric_limits<double>::infinity();
  for (int order = 1; order <= highest; ++order) {
    const Eigen::MatrixXd a = design(order);
    const double rss = (y - a * a.colPivHouseholderQr().solve(y)).squaredNorm();
    const double bic = dn * std::log(std::max(rss, dn * 1e-12) / dn) + static_cast<double>(a.cols()) * std::log(dn);
    if (bic < best_bic - 1e-9) {
      best_bic = bic;
      best = order;
    }
  }
  Block b;
  b.columns = design(best);
  for (int k = 1; k <= best; ++k) b.names.push_back("straightness_b" + std::to_string(k) + "_urad");
  for (std::size_t f = 1; f < l.files; ++f) b.names.push_back("file" + std::to_string(f + 1) + ".offset_urad");
  note = "base: the straightness polynomial of order " + std::to_string(best) + " (BIC, 1.." + std::to_string(highest) +
         ") common to every pass" + (l.files > 1 ? ", an offset per file after the first" : "");
  return b;
}

}  // namespace

Problem traverse_problem(const std::vector<TraversePass>& passes) {
  const Layout l = layout_of(passes);
  Problem p;
  p.model = "traverse";
  p.domain = "position_mm";
  p.timed = l.timed;
  std::vector<effects::Tp> g;
  std::vector<double> file_t0(l.files, std::numeric_limits<double>::quiet_NaN());
  for (const TraversePass& pass : passes)
    if (l.timed)
      file_t0[pass.file] =
          std::isnan(file_t0[pass.file]) ? pass.t_s.front() : std::min(file_t0[pass.file], pass.t_s.front());
  std::size_t index = 0;
  for (std::size_t k = 0; k < passes.size(); ++k) {
    const TraversePass& pass = passes[k];
    const double t0 = l.timed ? file_t0[pass.file] : 0.0;
    for (std::size_t i = 0; i < pass.x_m.size(); ++i, ++index) {
      // Without times, each reading counts one: the locations then speak of readings (Problem::timed).
      const double t = l.timed ? pass.t_s[i] - t0 : static_cast<double>(index);
      g.push_back({k, pass.x_m[i] + pass.step_m / 2, t, pass.direction, l.yaw ? pass.yaw_rad[i] * 1e6 : 0.0});
      if (!std::isfinite(pass.pitch_rad[i])) throw std::invalid_argument(pass.source + ": a reading is not finite");
      p.samples.push_back({k, std::tan(pass.pitch_rad[i]) * 1e6, pass.x_m[i] * 1e3, t});
    }
    p.runs.push_back({"pass" + std::to_string(k + 1) + (pass.direction > 0 ? " (+)" : " (-)"), pass.direction, 0.0,
                      "traverse", pass.source, g[index - pass.x_m.size()].t_s});
  }
  Eigen::VectorXd y(static_cast<Eigen::Index>(p.samples.size()));
  for (std::size_t i = 0; i < p.samples.size(); ++i) y[static_cast<Eigen::Index>(i)] = p.samples[i].y_um;
  std::string base_note;
  p.base = base_block(passes, l, y, base_note);
  const effects::TraverseTerms terms{g, l.both, l.timed, l.yaw, l.span_m, l.step_m};
  p.candidates = effects::traverse_candidates(terms);
  // A term's size across every pass: a rocking is constant along each pass, +r one way and -r the other.
  p.contribution_of = [](const Eigen::VectorXd& term) { return term.maxCoeff() - term.minCoeff(); };
  p.notes.push_back("what is explained: the pitch readings as slopes, in urad (= um/m); the report's um are urad");
  p.notes.push_back(base_note);
  if (!l.both) p.notes.push_back("passes one way only: an angle that flips with the direction of travel is not seen");
  if (!l.timed)
    p.notes.push_back("no pass back or repeat with times (t_s): a drift in time is a slope in x, part of the base");
  return p;
}

Report explain_traverses(const std::vector<TraversePass>& passes, const ExplainOptions& options) {
  return explain(traverse_problem(passes), options);
}

}  // namespace guideway::models::explain
