#include "sessions/dbb_session.hpp"

#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>

#include "sessions/session_support.hpp"
#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"
#include "models/dbb/json.hpp"
#include "models/explain/dbb_explain.hpp"

namespace guideway::sessions {

namespace {

constexpr double pi = std::numbers::pi;

struct Pattern {
  double radius_m;
  double height_m;
  formats::DbbDirection direction;
};

struct DbbOptions {
  std::vector<Pattern> patterns;
  double radius_tolerance_m = 1e-3;
  double min_speed_m_per_s = 0.5e-3;  // 30 mm/min: slower counts as standing still
  std::string plane = "xy";
};

// Lai's three patterns (Tables 2 and 4): one 100 mm bar, socket height 31.225 mm at r = 95 mm in
// both directions, and h = 0 at r = 100 mm counter-clockwise.
std::vector<Pattern> lai_patterns() {
  return {{95e-3, 31.225e-3, formats::DbbDirection::cw}, {95e-3, 31.225e-3, formats::DbbDirection::ccw},
          {100e-3, 0.0, formats::DbbDirection::ccw}};
}

DbbOptions parse_options(const nlohmann::json& o) {
  check_option_names(o, results::dbb_kind);
  DbbOptions d;
  d.radius_tolerance_m = number_option(o, results::dbb_radius_tolerance_mm) * 1e-3;
  d.min_speed_m_per_s = number_option(o, results::dbb_min_speed_mm_per_min) / 60e3;
  if (auto it = o.find(std::string(results::dbb_plane.name)); it != o.end()) {
    if (!it->is_string() || (*it != "xy" && *it != "xz" && *it != "yz")) {
      throw std::invalid_argument("option plane must be \"xy\", \"xz\" or \"yz\"");
    }
    d.plane = it->get<std::string>();
  }
  auto it = o.find(std::string(results::dbb_patterns.name));
  if (it == o.end()) {
    d.patterns = lai_patterns();
    return d;
  }
  if (!it->is_array() || it->empty()) {
    throw std::invalid_argument("option patterns must be a non-empty array of {radius_mm, height_mm, direction}");
  }
  for (const auto& p : *it) {
    if (!p.is_object()) throw std::invalid_argument("each pattern must be an object {radius_mm, height_mm, direction}");
    Pattern pat{number_option(p, "radius_mm", 100.0, 1.0, 2000.0) * 1e-3,
                number_option(p, "height_mm", 0.0, 0.0, 2000.0) * 1e-3, formats::DbbDirection::ccw};
    const std::string dir = p.value("direction", "ccw");
    if (dir != "ccw" && dir != "cw") throw std::invalid_argument("pattern direction must be \"ccw\" or \"cw\"");
    pat.direction = dir == "ccw" ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
    d.patterns.push_back(pat);
  }
  return d;
}

struct Point {
  double t_s;
  double bar_m;
  double a_m;  // first plane axis
  double b_m;  // second plane axis
};

// Algebraic (Kasa) circle fit: centre and radius minimising sum((x-a)^2 + (y-b)^2 - r^2)^2.
bool fit_circle(const std::vector<Point>& pts, std::size_t from, std::size_t to, double& ca, double& cb, double& r) {
  const std::size_t n = to - from;
  if (n < 10) return false;
  double ma = 0, mb = 0;
  for (std::size_t i = from; i < to; ++i) {
    ma += pts[i].a_m;
    mb += pts[i].b_m;
  }
  ma /= static_cast<double>(n);
  mb /= static_cast<double>(n);
  double suu = 0, svv = 0, suv = 0, suuu = 0, svvv = 0, suvv = 0, svuu = 0;
  for (std::size_t i = from; i < to; ++i) {
    const double u = pts[i].a_m - ma, v = pts[i].b_m - mb;
    suu += u * u;
    svv += v * v;
    suv += u * v;
    suuu += u * u * u;
    svvv += v * v * v;
    suvv += u * v * v;
    svuu += v * u * u;
  }
  const double det = suu * svv - suv * suv;
  if (std::abs(det) < 1e-30) return false;
  const double rhs_u = 0.5 * (suuu + suvv), rhs_v = 0.5 * (svvv + svuu);
  const double uc = (rhs_u * svv - rhs_v * suv) / det;
  const double vc = (suu * rhs_v - suv * rhs_u) / det;
  ca = uc + ma;
  cb = vc + mb;
  r = std::sqrt(uc * uc + vc * vc + (suu + svv) / static_cast<double>(n));
  return std::isfinite(r);
}

class DbbSession : public Session {
 public:
  DbbSession(DbbOptions options, const drivers::Driver& device, const Instrument& instrument)
      : options_(std::move(options)), bar_length_u_um_(instrument.calibrated_length_u_um.value_or(0.0)) {
    const auto& ch = device.channels();
    for (std::size_t i = 0; i < ch.size(); ++i) {
      if (ch[i].name == "bar_length") {
        bar_ = static_cast<int>(i);
      } else if (axis_a_ < 0) {
        axis_a_ = static_cast<int>(i);
      } else if (axis_b_ < 0) {
        axis_b_ = static_cast<int>(i);
      }
    }
    if (bar_ < 0 || axis_a_ < 0 || axis_b_ < 0) {
      throw std::invalid_argument("device " + device.name() + " needs a bar_length channel and two axis channels");
    }
    runs_.resize(options_.patterns.size());
  }

  void on_samples(std::span<const Sample> samples) override {
    for (const Sample& s : samples) {
      if (s.flags & (sample_partial | sample_out_of_range | sample_no_signal)) continue;  // incomplete cycle
      const std::size_t needed = static_cast<std::size_t>(std::max({bar_, axis_a_, axis_b_})) + 1;
      if (s.value_count < needed) continue;
      Point p{static_cast<double>(s.t_mono_ns) * 1e-9, s.value[static_cast<std::size_t>(bar_)],
              s.value[static_cast<std::size_t>(axis_a_)], s.value[static_cast<std::size_t>(axis_b_)]};
      if (t0_ < 0) t0_ = p.t_s;
      p.t_s -= t0_;
      const bool moving = is_moving(p);
      if (moving) {
        segment_.push_back(p);
        still_ = 0;
      } else if (!segment_.empty() && ++still_ > 5) {
        close_segment();
      }
      last_ = p;
      have_last_ = true;
    }
  }

  [[nodiscard]] bool complete() const override {
    for (const auto& r : runs_) {
      if (!r) return false;
    }
    return true;
  }

  [[nodiscard]] std::string progress() const override {
    std::size_t done = 0;
    for (const auto& r : runs_) done += r ? 1 : 0;
    std::ostringstream o;
    o << done << "/" << runs_.size() << " patterns traced";
    if (!segment_.empty()) o << ", tracing (" << segment_.size() << " samples)";
    if (!last_note_.empty()) o << "; " << last_note_;
    return o.str();
  }

  nlohmann::json identify() override {
    if (!segment_.empty()) close_segment();  // a stop in the middle of a circle keeps what is complete
    // Identified from exactly what the run files hold, so `guideway identify dbb` on them agrees.
    std::vector<formats::DbbRun> runs;
    for (const auto& r : runs_) {
      if (r) runs.push_back(formats::parse_dbb_run(formats::format_dbb_run(*r), r->source));
    }
    if (runs.empty()) {
      throw std::runtime_error("no complete DBB circle was traced" + (last_note_.empty() ? "" : " (" + last_note_ + ")"));
    }
    models::dbb::IdentifyOptions identify_options;
    identify_options.bar_length_u_um = bar_length_u_um_;
    const models::dbb::Identification id = models::dbb::identify(runs, identify_options);
    identified_ = runs;
    nlohmann::json j = models::dbb::to_json(id);
    if (runs.size() < runs_.size()) {
      j["incomplete"] = std::to_string(runs.size()) + " of " + std::to_string(runs_.size()) + " patterns traced";
    }
    return j;
  }

  std::optional<nlohmann::json> explain() override {
    if (identified_.empty()) return std::nullopt;
    try {
      return models::explain::explain_dbb(identified_);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(e.what());
    }
  }

  [[nodiscard]] std::map<std::string, std::string> metadata() const override {
    std::ostringstream p;
    for (const auto& pat : options_.patterns) {
      p << (p.tellp() > 0 ? "; " : "") << "r=" << pat.radius_m * 1e3 << "mm h=" << pat.height_m * 1e3
        << "mm " << (pat.direction == formats::DbbDirection::ccw ? "ccw" : "cw");
    }
    return {{"patterns", p.str()}, {"plane", options_.plane}};
  }

  std::vector<std::string> write_derived(const std::string& dir, const std::string& base_name) override {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < runs_.size(); ++i) {
      if (!runs_[i]) continue;
      const std::string path = dir + "/" + base_name + ".run" + std::to_string(i + 1) + ".csv";
      formats::write_dbb_run(*runs_[i], path);
      out.push_back(path);
    }
    return out;
  }

 private:
  bool is_moving(const Point& p) {
    if (!have_last_) return false;
    const double dt = p.t_s - last_.t_s;
    if (dt <= 0) return !segment_.empty();
    const double v = std::hypot(p.a_m - last_.a_m, p.b_m - last_.b_m) / dt;
    return v > options_.min_speed_m_per_s;
  }

  void close_segment() {
    std::vector<Point> seg;
    seg.swap(segment_);
    double ca = 0, cb = 0, r = 0;
    if (!fit_circle(seg, 0, seg.size(), ca, cb, r)) return;
    // Keep the samples on the circle (feed-in moves are radial), refit on them.
    std::vector<Point> on;
    for (const Point& p : seg) {
      if (std::abs(std::hypot(p.a_m - ca, p.b_m - cb) - r) < options_.radius_tolerance_m) on.push_back(p);
    }
    if (!fit_circle(on, 0, on.size(), ca, cb, r)) return;
    std::vector<double> angle(on.size());
    for (std::size_t i = 0; i < on.size(); ++i) {
      angle[i] = std::atan2(on[i].b_m - cb, on[i].a_m - ca);
      if (i > 0) {
        double d = angle[i] - angle[i - 1];
        // Unwrap relative to the previous sample's unwrapped angle.
        d = std::remainder(angle[i] - std::remainder(angle[i - 1], 2 * pi), 2 * pi);
        angle[i] = angle[i - 1] + d;
      }
    }
    const double span = angle.back() - angle.front();
    if (std::abs(span) < 2 * pi) {
      std::ostringstream o;
      o << "ignored an arc of " << std::abs(span) * 180 / pi << " deg at r = " << r * 1e3 << " mm";
      last_note_ = o.str();
      return;
    }
    const auto dir = span > 0 ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
    std::size_t match = runs_.size();
    for (std::size_t i = 0; i < options_.patterns.size(); ++i) {
      const Pattern& pat = options_.patterns[i];
      if (!runs_[i] && pat.direction == dir && std::abs(pat.radius_m - r) < options_.radius_tolerance_m) {
        match = i;
        break;
      }
    }
    if (match == runs_.size()) {
      std::ostringstream o;
      o << "a " << (dir == formats::DbbDirection::ccw ? "ccw" : "cw") << " circle of r = " << r * 1e3
        << " mm matches no pattern still to trace";
      last_note_ = o.str();
      return;
    }
    // The central 360 deg of the swept arc: the overshoot arcs at both ends are dropped.
    const double mid = 0.5 * (angle.front() + angle.back());
    const double lo = mid - pi * static_cast<int>(dir), hi = mid + pi * static_cast<int>(dir);
    const Pattern& pat = options_.patterns[match];
    formats::DbbRun run;
    run.source = "pattern " + std::to_string(match + 1);
    run.radius_m = pat.radius_m;
    run.height_m = pat.height_m;
    run.direction = dir;
    run.plane = options_.plane;
    run.center_a_m = ca;
    run.center_b_m = cb;
    const double nominal = std::hypot(pat.radius_m, pat.height_m);
    for (std::size_t i = 0; i < on.size(); ++i) {
      const double rel = (angle[i] - lo) * static_cast<int>(dir);
      if (rel < 0 || rel > (hi - lo) * static_cast<int>(dir)) continue;
      run.t_s.push_back(on[i].t_s);
      run.angle_rad.push_back(angle[i]);
      run.dL_m.push_back(on[i].bar_m - nominal);
    }
    if (run.t_s.size() < 2) return;
    const double duration = run.t_s.back() - run.t_s.front();
    run.feed_m_per_s = duration > 0 ? 2 * pi * r / duration : 0.0;
    std::ostringstream feed;
    feed << run.feed_m_per_s * 60e3;
    run.metadata = {{"format", formats::dbb_run_format_id},
                    {"radius_mm", std::to_string(pat.radius_m * 1e3)},
                    {"height_mm", std::to_string(pat.height_m * 1e3)},
                    {"direction", dir == formats::DbbDirection::ccw ? "ccw" : "cw"},
                    {"feed_mm_per_min", feed.str()},
                    {"plane", options_.plane},
                    {"measured_radius_mm", std::to_string(r * 1e3)},
                    // The circle centre in machine coordinates (the encoders'), which compensation
                    // tables are placed by (docs/compensation.md); written also when it is 0.
                    {"center_a_mm", std::to_string(ca * 1e3)},
                    {"center_b_mm", std::to_string(cb * 1e3)},
                    // t_s of every run is on the session's clock: one machine-time axis for EXPLAIN's
                    // time-dependent effects (thermal drift), see docs/explain.md.
                    {"start_time_s", "0"},
                    // The angles are the axis encoders' (the drives' positions), not the commanded ones:
                    // EXPLAIN then needs no drive delay (docs/explain.md).
                    {"angle_source", "encoders"}};
    try {
      formats::validate_dbb_run(run);
    } catch (const formats::DbbRunFormatError& e) {
      last_note_ = std::string("pattern ") + std::to_string(match + 1) + " rejected: " + e.what();
      return;
    }
    runs_[match] = std::move(run);
    last_note_.clear();
  }

  DbbOptions options_;
  double bar_length_u_um_ = 0.0;             // the bar's calibrated length's u (0: not stated)
  std::vector<formats::DbbRun> identified_;  // what identify() fitted, for explain()
  int bar_ = -1, axis_a_ = -1, axis_b_ = -1;
  double t0_ = -1;
  Point last_{};
  bool have_last_ = false;
  int still_ = 0;
  std::vector<Point> segment_;
  std::vector<std::optional<formats::DbbRun>> runs_;
  std::string last_note_;
};

}  // namespace

SessionKind dbb_session_kind() {
  return {std::string(results::dbb_kind.name),
          results::description(results::dbb_kind),
          {"dbb-can"},
          [](const SessionRequest& r, const drivers::Driver& device) -> std::unique_ptr<Session> {
            return std::make_unique<DbbSession>(parse_options(r.options), device, r.instrument);
          }};
}

}  // namespace guideway::sessions
