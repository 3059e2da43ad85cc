// The "dbb" session (dbb_session.hpp): circles from the bar's samples, identified per plane, EXPLAIN beside.
#include "sessions/dbb_session.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>

#include "core/number_format.hpp"
#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"
#include "models/dbb/json.hpp"
#include "models/explain/dbb_checked.hpp"
#include "models/explain/dbb_explain.hpp"
#include "sessions/explain_options.hpp"
#include "sessions/session_support.hpp"

namespace guideway::sessions {

namespace {

constexpr double pi = std::numbers::pi;

// One circle of a test: where the bar is (radius, socket height, plane), which way the machine turns
// and the data arc it keeps (360 deg, or 220 deg in a vertical plane the table cuts).
struct Pattern {
  double radius_m = 0.1;
  double height_m = 0.0;
  formats::DbbDirection direction = formats::DbbDirection::ccw;
  std::string plane = "xy";
  double data_arc_rad = 2 * pi;
};

struct DbbOptions {
  std::string test = "standard";  // the template, or "patterns" when the circles are given
  std::vector<Pattern> patterns;
  double feed_m_per_s = 1000.0 / 60e3;  // 0: any feed
  double radius_tolerance_m = 1e-3;
  double min_speed_m_per_s = 0.5e-3;  // 30 mm/min: slower counts as standing still
  std::string plane = "xy";
};

const char* direction_name(formats::DbbDirection d) { return d == formats::DbbDirection::ccw ? "ccw" : "cw"; }

// The standard test: ccw then cw, full circles at h = 0 in the plane.
std::vector<Pattern> standard_patterns(double radius_m, const std::string& plane) {
  return {{radius_m, 0.0, formats::DbbDirection::ccw, plane}, {radius_m, 0.0, formats::DbbDirection::cw, plane}};
}

// The three-plane test: xy 360 deg, then xz and yz 220 deg (the arc above the centre: the table is
// below), each ccw then cw.
std::vector<Pattern> three_plane_patterns(double radius_m) {
  constexpr double vertical_arc_rad = 220.0 * pi / 180.0;
  std::vector<Pattern> out;
  for (const char* plane : {"xy", "xz", "yz"}) {
    const double arc = std::string(plane) == "xy" ? 2 * pi : vertical_arc_rad;
    for (auto dir : {formats::DbbDirection::ccw, formats::DbbDirection::cw})
      out.push_back({radius_m, 0.0, dir, plane, arc});
  }
  return out;
}

// Lai's three patterns (Tables 2 and 4): one 100 mm bar, socket height 31.225 mm at r = 95 mm in
// both directions, and h = 0 at r = 100 mm counter-clockwise.
std::vector<Pattern> lai_patterns(const std::string& plane) {
  return {{95e-3, 31.225e-3, formats::DbbDirection::cw, plane},
          {95e-3, 31.225e-3, formats::DbbDirection::ccw, plane},
          {100e-3, 0.0, formats::DbbDirection::ccw, plane}};
}

std::vector<Pattern> given_patterns(const nlohmann::json& list, const std::string& plane) {
  if (!list.is_array() || list.empty()) {
    throw std::invalid_argument(
        "option patterns must be a non-empty array of {radius_mm, height_mm, direction, plane, data_arc_deg}");
  }
  std::vector<Pattern> out;
  for (const auto& p : list) {
    if (!p.is_object()) {
      throw std::invalid_argument(
          "each pattern must be an object {radius_mm, height_mm, direction, plane, data_arc_deg}");
    }
    Pattern pat{number_option(p, "radius_mm", 100.0, 1.0, 2000.0) * 1e-3,
                number_option(p, "height_mm", 0.0, 0.0, 2000.0) * 1e-3, formats::DbbDirection::ccw,
                string_option(p, "plane", plane, {"xy", "xz", "yz"}),
                number_option(p, "data_arc_deg", 360.0, 180.0, 360.0) * pi / 180.0};
    const std::string dir = string_option(p, "direction", "ccw", {"ccw", "cw"});
    pat.direction = dir == "ccw" ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
    out.push_back(pat);
  }
  return out;
}

DbbOptions parse_options(const nlohmann::json& o) {
  check_option_names(o, results::dbb_kind);
  DbbOptions d;
  d.radius_tolerance_m = number_option(o, results::dbb_radius_tolerance_mm) * 1e-3;
  d.min_speed_m_per_s = number_option(o, results::dbb_min_speed_mm_per_min) / 60e3;
  d.feed_m_per_s = number_option(o, results::dbb_feed_mm_per_min) / 60e3;
  d.plane = string_option(o, results::dbb_plane);
  d.test = string_option(o, results::dbb_test);
  const auto given = [&](const results::SessionOption& opt) { return o.contains(std::string(opt.name)); };
  const double radius_m = number_option(o, results::dbb_radius_mm) * 1e-3;
  if (given(results::dbb_patterns)) {
    if (given(results::dbb_test) || given(results::dbb_radius_mm)) {
      throw std::invalid_argument("option patterns gives the circles: it does not go with option test or radius_mm");
    }
    d.test = std::string(results::dbb_patterns.name);
    d.patterns = given_patterns(o.at(std::string(results::dbb_patterns.name)), d.plane);
  } else if (d.test == "three-plane") {
    if (given(results::dbb_plane)) {
      throw std::invalid_argument(
          "the three-plane test has its planes (xy, then xz and yz): option plane is "
          "for the standard and lai tests");
    }
    d.patterns = three_plane_patterns(radius_m);
  } else if (d.test == "lai") {
    if (given(results::dbb_radius_mm)) {
      throw std::invalid_argument(
          "Lai's patterns have their radii (95 and 100 mm): option radius_mm is for the "
          "standard and three-plane tests");
    }
    d.patterns = lai_patterns(d.plane);
  } else {
    d.patterns = standard_patterns(radius_m, d.plane);
  }
  return d;
}

// One SYNC cycle's reading: the bar and the axes by letter (x, y, z; an axis without an encoder stays 0).
constexpr double no_period = std::numeric_limits<double>::quiet_NaN();

struct Reading {
  double t_s = 0.0;
  double bar_m = 0.0;
  std::array<double, 3> xyz_m{};
  double period = no_period;  // the controller's servo period it was read in (a virtual machine says it)
};

// A controller's commanded position, one servo period.
struct Commanded {
  double t_s;  // CLOCK_MONOTONIC
  std::array<double, 3> xyz_m;
  double period;  // the servo period's number (NaN: the device does not say)
};

// A reading in the plane of its circle.
struct Point {
  double t_s;
  double bar_m;
  double a_m;  // first plane axis
  double b_m;  // second plane axis
  double period;
};

// The axes' indices (0 = x, 1 = y, 2 = z) of a plane "xy", "xz" or "yz".
std::array<int, 2> plane_axes(const std::string& plane) { return {plane[0] - 'x', plane[1] - 'x'}; }

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
    find_channels(device);
    runs_.resize(options_.patterns.size());
  }

  void on_samples(std::span<const Sample> samples) override {
    for (const Sample& s : samples) {
      if (s.flags & (sample_partial | sample_out_of_range | sample_no_signal)) continue;  // incomplete cycle
      if (s.value_count < needed_values_) continue;
      Reading p{static_cast<double>(s.t_mono_ns) * 1e-9, s.value[static_cast<std::size_t>(bar_)], {}};
      for (std::size_t k = 0; k < 3; ++k) {
        if (axis_[k] >= 0) p.xyz_m[k] = s.value[static_cast<std::size_t>(axis_[k])];
      }
      if (period_ >= 0 && s.value_count > static_cast<std::uint32_t>(period_))
        p.period = s.value[static_cast<std::size_t>(period_)];
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

  // A controller's commanded positions (a device with channels x_cmd, y_cmd, z_cmd: LinuxCNC's linuxcnc-hal;
  // with a channel "period", each sample's servo period number), kept to write beside the bar's reading
  // (close_segment).
  void on_other_samples(const drivers::Driver& device, std::span<const Sample> samples) override {
    if (cmd_device_ == nullptr) {
      std::array<int, 3> ch{-1, -1, -1};
      int period = -1;
      const auto& channels = device.channels();
      for (std::size_t i = 0; i < channels.size(); ++i) {
        for (std::size_t k = 0; k < 3; ++k)
          if (channels[i].name == std::string(1, static_cast<char>('x' + k)) + "_cmd") ch[k] = static_cast<int>(i);
        if (channels[i].name == "period") period = static_cast<int>(i);
      }
      if (ch[0] < 0 || ch[1] < 0 || ch[2] < 0) return;
      cmd_device_ = &device;
      cmd_channel_ = ch;
      cmd_period_channel_ = period;
    }
    if (&device != cmd_device_) return;
    for (const Sample& s : samples) {
      if (s.value_count <= static_cast<std::uint32_t>(*std::max_element(cmd_channel_.begin(), cmd_channel_.end())))
        continue;
      Commanded c{static_cast<double>(s.t_mono_ns) * 1e-9, {}, no_period};
      for (std::size_t k = 0; k < 3; ++k) c.xyz_m[k] = s.value[static_cast<std::size_t>(cmd_channel_[k])];
      if (cmd_period_channel_ >= 0 && s.value_count > static_cast<std::uint32_t>(cmd_period_channel_))
        c.period = s.value[static_cast<std::size_t>(cmd_period_channel_)];
      commanded_.push_back(c);
    }
    // Hours at 1 kHz would grow without end: the oldest half goes (a circle is minutes).
    if (commanded_.size() > max_commanded) commanded_.erase(commanded_.begin(), commanded_.begin() + max_commanded / 2);
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

  // The circles still to trace at the test's feed (without one: the last run's), each its data arc plus the
  // feed-in and feed-out of the last run traced (none before the first), less what the one being traced has run.
  [[nodiscard]] std::optional<double> time_left_s() const override {
    const double v = options_.feed_m_per_s > 0 ? options_.feed_m_per_s : last_feed_m_per_s_;
    if (!(v > 0)) return std::nullopt;
    double left_s = 0;
    bool current = !segment_.empty();
    for (std::size_t i = 0; i < runs_.size(); ++i) {
      if (runs_[i]) continue;
      const Pattern& p = options_.patterns[i];
      double run_s = (p.data_arc_rad + 2 * last_overshoot_rad_) * p.radius_m / v;
      if (current) run_s = std::max(0.0, run_s - (segment_.back().t_s - segment_.front().t_s));
      current = false;
      left_s += run_s;
    }
    return left_s;
  }

  results::Params identify() override {
    if (!segment_.empty()) close_segment();  // a stop in the middle of a circle keeps what is complete
    // Identified from exactly what the run files hold, so `guideway identify dbb` on them agrees.
    std::map<std::string, std::vector<formats::DbbRun>> by_plane;
    std::size_t traced = 0;
    for (const auto& r : runs_) {
      if (!r) continue;
      // Runs read from their files (read_derived) are what the files hold already: read once more from their
      // text they could differ in a last digit (degrees to radians and back).
      by_plane[r->plane].push_back(runs_from_files_ ? *r
                                                    : formats::parse_dbb_run(formats::format_dbb_run(*r), r->source));
      ++traced;
    }
    if (traced == 0) {
      throw std::runtime_error("no complete DBB circle was traced" +
                               (last_note_.empty() ? "" : " (" + last_note_ + ")"));
    }
    models::dbb::IdentifyOptions identify_options;
    identify_options.bar_length_u_um = bar_length_u_um_;
    // One identification per plane: the first plane of the test (xy of the three-plane test) is the
    // PARAMS' body as for a one-plane test; every plane's is in its "planes".
    std::map<std::string, results::PlaneParams> planes;
    std::vector<models::dbb::Identification> ids;
    checked_.clear();
    std::optional<results::Params> first;
    for (const Pattern& pat : options_.patterns) {
      const auto it = by_plane.find(pat.plane);
      if (it == by_plane.end() || planes.contains(pat.plane)) continue;
      std::optional<results::Explanation> plane_explain;  // EXPLAIN's of this plane's runs, for explain()
      bool is_first = false;                              // the first plane identified: the PARAMS' body
      // As `guideway identify dbb` on the run files: what EXPLAIN finds beside the models' terms is fitted
      // beside them (a drift is not read as backlash), a term that contradicts EXPLAIN is not determined.
      try {
        const models::explain::CheckedIdentification checked =
            models::explain::identify_checked(it->second, identify_options, explain_options(*this));
        ids.push_back(checked.id);
        results::Params plane_params = models::explain::to_params(checked);
        planes[pat.plane].params = std::make_shared<const results::Params>(plane_params);
        is_first = !first;
        if (is_first) first = std::move(plane_params);
        plane_explain = checked.explanation;
        checked_.push_back(checked);
      } catch (const std::exception& e) {
        if (by_plane.size() == 1) throw;
        planes[pat.plane].error = e.what();
        continue;
      }
      if (is_first) {
        identified_ = it->second;
        explained_ = plane_explain;
      }
    }
    if (!first) throw std::runtime_error("no plane could be identified: " + results::planes_json(planes).dump());
    results::Params p = std::move(*first);
    if (planes.size() > 1) {
      p.planes = std::move(planes);
      if (ids.size() > 1) p.dbb.value().summary = models::dbb::planes_record(models::dbb::summarize_planes(ids));
    }
    p.test = options_.test;
    if (traced < runs_.size()) {
      p.incomplete = std::to_string(traced) + " of " + std::to_string(runs_.size()) + " patterns traced";
    }
    return p;
  }

  // What PARAMS published: each plane's identification, EXPLAIN's findings fitted beside.
  [[nodiscard]] const std::vector<models::explain::CheckedIdentification>* identified_planes() const override {
    return &checked_;
  }

  std::optional<results::Explanation> explain() override {
    if (identified_.empty()) return std::nullopt;
    if (explained_) return explained_;  // run by identify() already, on the same runs
    try {
      return models::explain::explain_dbb(identified_, explain_options(*this));
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(e.what());
    }
  }

  [[nodiscard]] std::map<std::string, std::string> metadata() const override {
    std::ostringstream p;
    std::string planes;
    for (const auto& pat : options_.patterns) {
      p << (p.tellp() > 0 ? "; " : "") << "r=" << pat.radius_m * 1e3 << "mm h=" << pat.height_m * 1e3 << "mm "
        << direction_name(pat.direction);
      if (pat.plane != options_.plane || pat.data_arc_rad < 2 * pi) {
        p << " " << pat.plane << " " << std::lround(pat.data_arc_rad * 180 / pi) << "deg";
      }
      if (planes.find(pat.plane) == std::string::npos) planes += (planes.empty() ? "" : ",") + pat.plane;
    }
    std::map<std::string, std::string> m{{"test", options_.test}, {"patterns", p.str()}, {"plane", planes}};
    if (options_.feed_m_per_s > 0) m["feed_mm_per_min"] = std::to_string(options_.feed_m_per_s * 60e3);
    return m;
  }

  std::vector<std::string> write_derived(const std::string& dir, const std::string& base_name) override {
    if (!segment_.empty()) close_segment();  // written before identify(): a stop mid-circle keeps what is complete
    std::vector<std::string> out;
    for (std::size_t i = 0; i < runs_.size(); ++i) {
      if (!runs_[i]) continue;
      const std::string path = dir + "/" + base_name + ".run" + std::to_string(i + 1) + ".csv";
      formats::write_dbb_run(*runs_[i], path);
      out.push_back(path);
    }
    return out;
  }

  // identify() takes the runs as their files hold them (parse of their format), so the files are all it needs.
  [[nodiscard]] bool identifies_from_derived() const override { return true; }

  void read_derived(const std::vector<std::string>& paths) override {
    for (const std::string& path : paths) {
      // BASE.runK.csv is pattern K's (write_derived).
      const auto dot = path.rfind(".run");
      std::size_t k = 0;
      const bool named = dot != std::string::npos && path.size() > dot + 8 && path.ends_with(".csv") &&
                         std::all_of(path.begin() + static_cast<std::ptrdiff_t>(dot + 4), path.end() - 4,
                                     [](char c) { return c >= '0' && c <= '9'; });
      if (named) k = std::stoul(path.substr(dot + 4, path.size() - 4 - dot - 4));
      if (!named || k == 0 || k > runs_.size()) {
        throw std::runtime_error(path + ": not a run file of this test's " + std::to_string(runs_.size()) +
                                 " patterns (BASE.runK.csv, K = 1.." + std::to_string(runs_.size()) + ")");
      }
      formats::DbbRun run = formats::read_dbb_run(path);
      run.source = "pattern " + std::to_string(k);  // as close_segment() names it
      runs_[k - 1] = std::move(run);
    }
    runs_from_files_ = true;
  }

 private:
  // The bar and the axis encoders: with x, y and z (channels so named) the plane of each circle is found
  // from the two that moved; with two axis channels they are the plane option's axes, whatever their names.
  void find_channels(const drivers::Driver& device) {
    const auto& ch = device.channels();
    std::vector<int> axes;
    std::array<int, 3> named{-1, -1, -1};
    for (std::size_t i = 0; i < ch.size(); ++i) {
      const std::string& name = ch[i].name;
      if (name == "bar_length") {
        bar_ = static_cast<int>(i);
        continue;
      }
      if (name == "controller_period") {  // a virtual machine's: the servo period it plays (docs/linuxcnc.md)
        period_ = static_cast<int>(i);
        continue;
      }
      axes.push_back(static_cast<int>(i));
      if (name.size() == 1 && name[0] >= 'x' && name[0] <= 'z')
        named[static_cast<std::size_t>(name[0] - 'x')] = static_cast<int>(i);
    }
    if (bar_ < 0 || axes.size() < 2) {
      throw std::invalid_argument("device " + device.name() + " needs a bar_length channel and two axis channels");
    }
    three_axes_ = named[0] >= 0 && named[1] >= 0 && named[2] >= 0;
    if (three_axes_) {
      axis_ = named;
    } else {
      const auto ab = plane_axes(options_.plane);
      axis_[static_cast<std::size_t>(ab[0])] = axes[0];
      axis_[static_cast<std::size_t>(ab[1])] = axes[1];
      for (const Pattern& pat : options_.patterns) {
        if (pat.plane == options_.plane) continue;
        throw std::invalid_argument("the " + options_.test + " test has circles in the " + pat.plane +
                                    " plane: it needs axis encoders named x, y and z on device " + device.name() +
                                    " (it has " + std::to_string(axes.size()) + " axis channels, read as the " +
                                    options_.plane + " plane)");
      }
    }
    needed_values_ = static_cast<std::size_t>(std::max({bar_, axis_[0], axis_[1], axis_[2]})) + 1;
  }

  bool is_moving(const Reading& p) {
    if (!have_last_) return false;
    const double dt = p.t_s - last_.t_s;
    if (dt <= 0) return !segment_.empty();
    double d2 = 0;
    for (std::size_t k = 0; k < 3; ++k) d2 += (p.xyz_m[k] - last_.xyz_m[k]) * (p.xyz_m[k] - last_.xyz_m[k]);
    return std::sqrt(d2) / dt > options_.min_speed_m_per_s;
  }

  // The plane of a stretch of motion: the two axes that moved most (the plane option's with two encoders).
  std::string plane_of(const std::vector<Reading>& seg) const {
    if (!three_axes_) return options_.plane;
    std::array<double, 3> range{};
    for (std::size_t k = 0; k < 3; ++k) {
      const auto [lo, hi] = std::minmax_element(
          seg.begin(), seg.end(), [k](const Reading& a, const Reading& b) { return a.xyz_m[k] < b.xyz_m[k]; });
      range[k] = hi->xyz_m[k] - lo->xyz_m[k];
    }
    const auto still = std::min_element(range.begin(), range.end()) - range.begin();
    return still == 0 ? "yz" : still == 1 ? "xz" : "xy";
  }

  // The first pattern still to trace that a circle of this plane, direction and radius is.
  std::size_t match_pattern(const std::string& plane, formats::DbbDirection dir, double r) const {
    for (std::size_t i = 0; i < options_.patterns.size(); ++i) {
      const Pattern& pat = options_.patterns[i];
      if (!runs_[i] && pat.plane == plane && pat.direction == dir &&
          std::abs(pat.radius_m - r) < options_.radius_tolerance_m) {
        return i;
      }
    }
    return runs_.size();
  }

  void close_segment() {
    std::vector<Reading> seg;
    seg.swap(segment_);
    if (seg.size() < 10) return;
    const std::string plane = plane_of(seg);
    const auto [ia, ib] = plane_axes(plane);
    std::vector<Point> pts;
    pts.reserve(seg.size());
    for (const Reading& q : seg) {
      pts.push_back(
          {q.t_s, q.bar_m, q.xyz_m[static_cast<std::size_t>(ia)], q.xyz_m[static_cast<std::size_t>(ib)], q.period});
    }
    double ca = 0, cb = 0, r = 0;
    if (!fit_circle(pts, 0, pts.size(), ca, cb, r)) return;
    // Where the circle lies along the plane's normal (its third encoder; 0 without one): the error map places it.
    double cn = 0;
    for (const Reading& q : seg) cn += q.xyz_m[static_cast<std::size_t>(3 - ia - ib)] / static_cast<double>(seg.size());
    // Keep the samples on the circle (feed-in moves are radial), refit on them.
    std::vector<Point> on;
    for (const Point& p : pts) {
      if (std::abs(std::hypot(p.a_m - ca, p.b_m - cb) - r) < options_.radius_tolerance_m) on.push_back(p);
    }
    if (!fit_circle(on, 0, on.size(), ca, cb, r)) return;
    std::vector<double> angle(on.size());
    for (std::size_t i = 0; i < on.size(); ++i) {
      angle[i] = std::atan2(on[i].b_m - cb, on[i].a_m - ca);
      // Unwrapped relative to the previous sample's unwrapped angle.
      if (i > 0) angle[i] = angle[i - 1] + std::remainder(angle[i] - std::remainder(angle[i - 1], 2 * pi), 2 * pi);
    }
    const double span = angle.back() - angle.front();
    const auto dir = span > 0 ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
    std::ostringstream what;
    // To a tenth of a degree: a circle cut short by a few samples is not "360 deg shorter than 360 deg".
    what << "a " << direction_name(dir) << " arc of " << printf_number("%.1f", std::abs(span) * 180 / pi) << " deg in "
         << plane << " at r = " << r * 1e3 << " mm";
    const std::size_t match = match_pattern(plane, dir, r);
    if (match == runs_.size()) {
      last_note_ = what.str() + " matches no pattern still to trace";
      return;
    }
    const Pattern& pat = options_.patterns[match];
    if (std::abs(span) < pat.data_arc_rad) {
      last_note_ = what.str() + " is shorter than pattern " + std::to_string(match + 1) + "'s data arc of " +
                   std::to_string(std::lround(pat.data_arc_rad * 180 / pi)) + " deg: ignored";
      return;
    }
    // The central data arc of the swept arc: the feed-in/feed-out overshoot at both ends is dropped.
    const double mid = 0.5 * (angle.front() + angle.back());
    const double half = 0.5 * pat.data_arc_rad;
    formats::DbbRun run;
    run.source = "pattern " + std::to_string(match + 1);
    run.radius_m = pat.radius_m;
    run.height_m = pat.height_m;
    run.direction = dir;
    run.plane = plane;
    run.center_a_m = ca;
    run.center_b_m = cb;
    const double nominal = std::hypot(pat.radius_m, pat.height_m);
    std::vector<double> run_periods;  // the rows' servo periods (NaN: not said)
    for (std::size_t i = 0; i < on.size(); ++i) {
      if (std::abs(angle[i] - mid) > half) continue;
      run_periods.push_back(on[i].period);
      run.t_s.push_back(on[i].t_s);
      run.angle_rad.push_back(angle[i]);
      run.dL_m.push_back(on[i].bar_m - nominal);
    }
    if (run.t_s.size() < 2) return;
    const double duration = run.t_s.back() - run.t_s.front();
    run.feed_m_per_s = duration > 0 ? pat.data_arc_rad * r / duration : 0.0;
    if (options_.feed_m_per_s > 0 && std::abs(run.feed_m_per_s / options_.feed_m_per_s - 1) > 0.1) {
      std::ostringstream o;
      o << what.str() << " was traced at " << std::lround(run.feed_m_per_s * 60e3) << " mm/min; the test's feed is "
        << std::lround(options_.feed_m_per_s * 60e3) << " mm/min (option feed_mm_per_min): ignored";
      last_note_ = o.str();
      return;
    }
    // The swept arc beyond the data arc, half before and half after it: the test's feed-in and feed-out.
    run.metadata = run_metadata(pat, run, r, ca, cb, cn, 0.5 * (std::abs(span) - pat.data_arc_rad));
    try {
      formats::validate_dbb_run(run);
    } catch (const formats::DbbRunFormatError& e) {
      last_note_ = std::string("pattern ") + std::to_string(match + 1) + " rejected: " + e.what();
      return;
    }
    add_commanded(run, on, run_periods);
    last_feed_m_per_s_ = run.feed_m_per_s;
    last_overshoot_rad_ = 0.5 * (std::abs(span) - pat.data_arc_rad);
    runs_[match] = std::move(run);
    last_note_.clear();
  }

  // The controller's command at CLOCK_MONOTONIC time t_s along the axes a, b (linear between its periods).
  std::array<double, 2> commanded_at(double t_s, int a, int b) const {
    auto hi = std::lower_bound(commanded_.begin(), commanded_.end(), t_s,
                               [](const Commanded& c, double t) { return c.t_s < t; });
    if (hi == commanded_.begin()) hi = commanded_.begin() + 1;
    if (hi == commanded_.end()) hi = commanded_.end() - 1;
    const auto lo = hi - 1;
    const double w = hi->t_s > lo->t_s ? std::clamp((t_s - lo->t_s) / (hi->t_s - lo->t_s), 0.0, 1.0) : 0.0;
    const auto at = [&](int k) {
      const auto i = static_cast<std::size_t>(k);
      return lo->xyz_m[i] + w * (hi->xyz_m[i] - lo->xyz_m[i]);
    };
    return {at(a), at(b)};
  }

  // The controller's commanded position beside each reading of the run (columns <a>_cmd_mm, <b>_cmd_mm): the
  // command the encoders were following, a lag earlier (the drives' following lag, and the links' latency when
  // matched by time). Where the readings and the commands both say their servo period (a virtual machine
  // following LinuxCNC: its controller_period channel, linuxcnc-hal's period), they are paired by it: exact
  // whatever the arrival times did (add_commanded_by_period). Else by time (add_commanded_by_time).
  void add_commanded(formats::DbbRun& run, const std::vector<Point>& on, const std::vector<double>& run_periods) {
    if (commanded_.size() < 2 || run.t_s.size() < 2) return;
    const bool by_period =
        std::all_of(run_periods.begin(), run_periods.end(), [](double p) { return std::isfinite(p); }) &&
        std::isfinite(commanded_.back().period);
    if (by_period) {
      add_commanded_by_period(run, on, run_periods);
    } else {
      add_commanded_by_time(run, on);
    }
  }

  // The command of servo period p (fractional: linear between periods) in `stretch`, along the axes a, b;
  // nothing outside it.
  static std::optional<std::array<double, 2>> commanded_of_period(std::span<const Commanded> stretch, double p, int a,
                                                                  int b) {
    if (stretch.size() < 2 || p < stretch.front().period || p > stretch.back().period) return std::nullopt;
    auto hi =
        std::lower_bound(stretch.begin(), stretch.end(), p, [](const Commanded& c, double x) { return c.period < x; });
    if (hi == stretch.begin()) hi = stretch.begin() + 1;
    const auto lo = hi - 1;
    const double w = (p - lo->period) / (hi->period - lo->period);
    const auto at = [&](int k) {
      const auto i = static_cast<std::size_t>(k);
      return lo->xyz_m[i] + w * (hi->xyz_m[i] - lo->xyz_m[i]);
    };
    return std::array<double, 2>{at(a), at(b)};
  }

  // Paired by servo period: the reading played in period p sits beside the command of period p - lag, the lag
  // (the drives', in periods: one for the run, it does not drift) found where the encoders follow the command
  // best. The periods come from one LinuxCNC run (a restart numbers its periods from 0 again): of the
  // stretches of rising numbers holding the run's, the one whose commands came nearest the run's last reading
  // in time. The run also carries controller_period, the
  // period each reading was played in, so that anyone can pair it with the bridge's stream.
  void add_commanded_by_period(formats::DbbRun& run, const std::vector<Point>& on,
                               const std::vector<double>& run_periods) {
    const std::array<int, 2> axes = plane_axes(run.plane);
    const int ia = axes[0], ib = axes[1];  // not a structured binding: clang 14 cannot capture one (the lambda below)
    // The stretches of rising period numbers that hold the run's periods; of them, the one that came nearest
    // before the run's last reading.
    const double first_p = *std::min_element(run_periods.begin(), run_periods.end());
    const double last_p = *std::max_element(run_periods.begin(), run_periods.end());
    const double last_t = run.t_s.back() + t0_;
    std::size_t begin = 0, end = 0;
    double best_gap = std::numeric_limits<double>::infinity();
    for (std::size_t b = 0; b < commanded_.size();) {
      std::size_t e = b + 1;
      while (e < commanded_.size() && commanded_[e].period > commanded_[e - 1].period) ++e;
      const std::span<const Commanded> s(commanded_.data() + b, e - b);
      if (s.front().period <= first_p && s.back().period >= last_p) {
        const auto at =
            std::lower_bound(s.begin(), s.end(), last_p, [](const Commanded& c, double x) { return c.period < x; });
        if (const double gap = std::abs(last_t - at->t_s); gap < best_gap) best_gap = gap, begin = b, end = e;
      }
      b = e;
    }
    if (end == begin) return;
    const std::span<const Commanded> stretch(commanded_.data() + begin, end - begin);
    std::vector<const Point*> kept;
    for (const Point& p : on)
      if (p.t_s >= run.t_s.front() && p.t_s <= run.t_s.back() && std::isfinite(p.period)) kept.push_back(&p);
    if (kept.size() < 20) return;
    const std::size_t stride = std::max<std::size_t>(1, kept.size() / 400);
    const auto mismatch = [&](double lag) {
      double sum = 0;
      std::size_t n = 0;
      for (std::size_t i = 0; i < kept.size(); i += stride, ++n) {
        const auto c = commanded_of_period(stretch, kept[i]->period - lag, ia, ib);
        if (!c) return std::numeric_limits<double>::infinity();
        sum += std::hypot(kept[i]->a_m - (*c)[0], kept[i]->b_m - (*c)[1]);
      }
      return sum / static_cast<double>(n);
    };
    double best = 0, best_m = mismatch(0.0), step = 1.0;
    for (double lag = step; lag <= max_following_lag_periods; lag += step)
      if (const double m = mismatch(lag); m < best_m) best = lag, best_m = m;
    if (!std::isfinite(best_m)) return;  // the commands do not reach back over the run
    for (int pass = 0; pass < 2; ++pass) {
      const double centre = best;
      for (double lag = std::max(0.0, centre - step); lag <= centre + step; lag += step / 25)
        if (const double m = mismatch(lag); m < best_m) best = lag, best_m = m;
      step /= 25;
    }
    best = std::round(best * 1e3) * 1e-3;  // as controller_lag_periods says it: the columns read back from it
    std::vector<double> a_mm, b_mm;
    for (const double p : run_periods) {
      const auto c = commanded_of_period(stretch, p - best, ia, ib);
      if (!c) return;
      a_mm.push_back((*c)[0] * 1e3);
      b_mm.push_back((*c)[1] * 1e3);
    }
    double sum = 0;
    for (const Point* p : kept) {
      const auto c = commanded_of_period(stretch, p->period - best, ia, ib);
      sum += std::hypot(p->a_m - (*c)[0], p->b_m - (*c)[1]);
    }
    // The servo period's length: the device stamps the periods of a batch one period apart.
    std::vector<double> dt;
    for (std::size_t i = 1; i < stretch.size(); i += std::max<std::size_t>(1, stretch.size() / 1000))
      if (stretch[i].period - stretch[i - 1].period == 1.0) dt.push_back(stretch[i].t_s - stretch[i - 1].t_s);
    double period_s = 0;
    if (!dt.empty()) {
      std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
      period_s = dt[dt.size() / 2];
    }
    run.extra_columns = {{std::string(1, run.plane[0]) + "_cmd_mm", std::move(a_mm)},
                         {std::string(1, run.plane[1]) + "_cmd_mm", std::move(b_mm)},
                         {"controller_period", run_periods}};
    run.metadata["controller"] = cmd_device_->name();
    run.metadata["controller_match"] = "servo period";
    run.metadata["controller_lag_periods"] = printf_number("%.3f", best);
    run.metadata["controller_lag_ms"] = printf_number("%.1f", best * period_s * 1e3);
    run.metadata["controller_lag_spread_ms"] = "0";
    run.metadata["controller_mismatch_um"] = printf_number("%.3g", sum / static_cast<double>(kept.size()) * 1e6);
  }

  // Paired by time: the command taken the time earlier at which the encoders follow it best: the drives' lag
  // and the links' latency. That time drifts where the readings' clock and the controller's differ (a virtual
  // machine playing LinuxCNC's periods back a second behind, its clock taking up LinuxCNC's 1 % drift: 0.16 s
  // over a 16 s run; not its stalls, which only the period numbers pair: 0.15 to 1 mm off), so it is tracked
  // window by window (a second of the run each) and interpolated between them. The metadata states it
  // (controller_lag_ms: mean, controller_lag_spread_ms: largest less smallest) and how far the encoders stayed
  // from the command (controller_mismatch_um, mean). Nothing when no controller's device streamed over the run.
  void add_commanded_by_time(formats::DbbRun& run, const std::vector<Point>& on) {
    const std::array<int, 2> axes = plane_axes(run.plane);
    const int ia = axes[0], ib = axes[1];  // not a structured binding: clang 14 cannot capture one (the lambda below)
    std::vector<const Point*> kept;  // the run's samples
    for (const Point& p : on)
      if (p.t_s >= run.t_s.front() && p.t_s <= run.t_s.back()) kept.push_back(&p);
    if (kept.size() < 20) return;
    // Mean distance of the samples [from, to) (every stride-th) from the command lag earlier.
    const auto mismatch = [&](std::size_t from, std::size_t to, std::size_t stride, double lag) {
      double sum = 0;
      std::size_t n = 0;
      for (std::size_t i = from; i < to; i += stride, ++n) {
        const auto c = commanded_at(kept[i]->t_s + t0_ - lag, ia, ib);
        sum += std::hypot(kept[i]->a_m - c[0], kept[i]->b_m - c[1]);
      }
      return sum / static_cast<double>(std::max<std::size_t>(n, 1));
    };
    // The best lag over [0, max_controller_lag_s]: on a 20 ms grid, then on grids 1/25 and 1/625 as fine about
    // it (the mismatch grows with the feed times the lag's error: one minimum within a revolution). Each window
    // searches the whole range: the lag jumps where a virtual machine's playback ran dry and waits longer.
    const auto search = [&](std::size_t from, std::size_t to) {
      const std::size_t stride = std::max<std::size_t>(1, (to - from) / 100);
      double best = 0, best_m = mismatch(from, to, stride, 0.0), step = 0.02;
      for (double lag = step; lag <= max_controller_lag_s; lag += step)
        if (const double m = mismatch(from, to, stride, lag); m < best_m) best = lag, best_m = m;
      for (int pass = 0; pass < 2; ++pass) {
        const double centre = best;
        for (double lag = std::max(0.0, centre - step); lag <= centre + step; lag += step / 25)
          if (const double m = mismatch(from, to, stride, lag); m < best_m) best = lag, best_m = m;
        step /= 25;
      }
      return best;
    };
    std::vector<std::pair<double, double>> track;  // (run time, lag) at each window's middle
    for (std::size_t from = 0; from < kept.size();) {
      std::size_t to = from;
      while (to < kept.size() && kept[to]->t_s < kept[from]->t_s + lag_window_s) ++to;
      if (kept.size() - to < 20) to = kept.size();  // a short tail joins the last window
      track.emplace_back(0.5 * (kept[from]->t_s + kept[to - 1]->t_s), search(from, to));
      from = to;
    }
    // Linear between the windows' middles, and beyond the first and the last (the drift goes on to the ends).
    const auto lag_at = [&](double t) {
      if (track.size() == 1) return track.front().second;
      auto hi = std::lower_bound(track.begin(), track.end(), t, [](const auto& w, double x) { return w.first < x; });
      hi = std::clamp(hi, track.begin() + 1, track.end() - 1);
      const auto lo = hi - 1;
      return lo->second + (t - lo->first) / (hi->first - lo->first) * (hi->second - lo->second);
    };
    const double first = run.t_s.front() + t0_ - lag_at(run.t_s.front());
    const double last = run.t_s.back() + t0_ - lag_at(run.t_s.back());
    if (first < commanded_.front().t_s || last > commanded_.back().t_s) return;  // not over the whole run
    std::vector<double> a_mm, b_mm;
    for (const double t : run.t_s) {
      const auto c = commanded_at(t + t0_ - lag_at(t), ia, ib);
      a_mm.push_back(c[0] * 1e3);
      b_mm.push_back(c[1] * 1e3);
    }
    double sum = 0, lo = track.front().second, hi = lo, lag_sum = 0;
    for (const Point* p : kept) {
      const double l = lag_at(p->t_s);
      const auto c = commanded_at(p->t_s + t0_ - l, ia, ib);
      sum += std::hypot(p->a_m - c[0], p->b_m - c[1]);
      lag_sum += l;
    }
    for (const auto& w : track) lo = std::min(lo, w.second), hi = std::max(hi, w.second);
    const auto n = static_cast<double>(kept.size());
    run.extra_columns = {{std::string(1, run.plane[0]) + "_cmd_mm", std::move(a_mm)},
                         {std::string(1, run.plane[1]) + "_cmd_mm", std::move(b_mm)}};
    run.metadata["controller"] = cmd_device_->name();
    run.metadata["controller_match"] = "arrival time";
    run.metadata["controller_lag_ms"] = printf_number("%.1f", lag_sum / n * 1e3);
    run.metadata["controller_lag_spread_ms"] = printf_number("%.1f", (hi - lo) * 1e3);
    run.metadata["controller_mismatch_um"] = printf_number("%.3g", sum / n * 1e6);
  }

  std::map<std::string, std::string> run_metadata(const Pattern& pat, const formats::DbbRun& run, double r, double ca,
                                                  double cb, double cn, double overshoot_rad) const {
    std::ostringstream feed;
    feed << run.feed_m_per_s * 60e3;
    return {{"format", formats::dbb_run_format_id},
            {"test", options_.test},
            {"radius_mm", std::to_string(pat.radius_m * 1e3)},
            {"height_mm", std::to_string(pat.height_m * 1e3)},
            {"direction", direction_name(run.direction)},
            {"feed_mm_per_min", feed.str()},
            {"plane", run.plane},
            {"data_arc_deg", std::to_string(pat.data_arc_rad * 180 / pi)},
            {"overshoot_deg", std::to_string(overshoot_rad * 180 / pi)},
            {"measured_radius_mm", std::to_string(r * 1e3)},
            // The circle centre in machine coordinates (the encoders'), which compensation
            // tables are placed by (docs/compensation.md); written also when it is 0.
            {"center_a_mm", std::to_string(ca * 1e3)},
            {"center_b_mm", std::to_string(cb * 1e3)},
            {"center_n_mm", std::to_string(cn * 1e3)},
            // t_s of every run is on the session's clock: one machine-time axis for EXPLAIN's
            // time-dependent effects (thermal drift), see docs/explain.md.
            {"start_time_s", "0"},
            // The angles are the axis encoders' (the drives' positions), not the commanded ones:
            // EXPLAIN then needs no drive delay (docs/explain.md).
            {"angle_source", "encoders"}};
  }

  DbbOptions options_;
  double bar_length_u_um_ = 0.0;             // the bar's calibrated length's u (0: not stated)
  std::vector<formats::DbbRun> identified_;  // what identify() fitted (the first plane's), for explain()
  std::optional<results::Explanation> explained_;                // EXPLAIN's of identified_, as identify() ran it
  std::vector<models::explain::CheckedIdentification> checked_;  // each plane's, as identify() published it
  int bar_ = -1;
  std::array<int, 3> axis_{-1, -1, -1};  // channel of x, y, z (-1: none)
  bool three_axes_ = false;
  std::size_t needed_values_ = 0;
  double t0_ = -1;
  Reading last_{};
  bool have_last_ = false;
  int still_ = 0;
  std::vector<Reading> segment_;
  std::vector<std::optional<formats::DbbRun>> runs_;
  bool runs_from_files_ = false;  // runs_ were read back from the session's run files (read_derived)
  std::string last_note_;
  static constexpr std::size_t max_commanded = 4'000'000;  // an hour at 1 kHz
  static constexpr double max_controller_lag_s = 10.0;     // a virtual machine plays the periods back seconds late
  static constexpr double lag_window_s = 1.0;
  std::vector<Commanded> commanded_;  // pipeline thread
  const drivers::Driver* cmd_device_ = nullptr;
  std::array<int, 3> cmd_channel_{-1, -1, -1};
  int cmd_period_channel_ = -1;
  int period_ = -1;                                          // the DBB device's controller_period channel (-1: none)
  static constexpr double max_following_lag_periods = 1000;  // the drives' lag, in servo periods
  double last_feed_m_per_s_ = 0.0;                           // of the last run traced (time_left_s)
  double last_overshoot_rad_ = 0.0;                          // its feed-in, and its feed-out
};

// A recording made before the test templates (no "test" in its header) ran Lai's patterns by default,
// at whatever feed.
nlohmann::json recorded_options(nlohmann::json options, const std::map<std::string, std::string>& header) {
  if (header.count(std::string(results::dbb_test.name)) > 0 || !options.is_object()) return options;
  if (!options.contains(std::string(results::dbb_patterns.name))) options[std::string(results::dbb_test.name)] = "lai";
  options[std::string(results::dbb_feed_mm_per_min.name)] = 0;
  return options;
}

}  // namespace

SessionKind dbb_session_kind() {
  return {std::string(results::dbb_kind.name),
          results::description(results::dbb_kind),
          {"dbb-can"},
          [](const SessionRequest& r, const drivers::Driver& device) -> std::unique_ptr<Session> {
            return std::make_unique<DbbSession>(parse_options(r.options), device, r.instrument);
          },
          &recorded_options};
}

}  // namespace guideway::sessions
