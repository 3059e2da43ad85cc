// The "straightness" session (straightness_session.hpp): an autocollimator traverse's stations, its straightness.
#include "sessions/straightness_session.hpp"

#include <cmath>
#include <sstream>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"
#include "models/explain/explanation.hpp"
#include "models/explain/traverse_explain.hpp"
#include "models/flatness/angles.hpp"
#include "models/flatness/json.hpp"
#include "models/flatness/straightness.hpp"
#include "results/parameters.hpp"
#include "sessions/explain_options.hpp"
#include "sessions/session_support.hpp"

namespace guideway::sessions {

namespace {

struct StraightnessOptions {
  double step_m = 0.01875;
  double start_m = 0.0;
  std::size_t stations = 0;  // per pass; 0: until the reflector is carried back
  std::size_t passes = 2;    // forward, back, forward... over the same stations
  bool wait_for_return = true;
  double return_gap_s = 1.0;
  double min_dwell_s = 0.3;
  double max_hole_s = 0.45;
  double settle_rad = 0.5 * models::flatness::rad_per_arcsec;
  int axis = 0;  // 0 x, 1 y, 2 z
  double pitch_sign = -1.0;
  double yaw_sign = 1.0;
  std::string pitch_channel = "angle_y";
  std::string yaw_channel = "angle_x";  // "" = no yaw
  models::flatness::StraightnessOptions model;
};

StraightnessOptions parse_options(const nlohmann::json& o) {
  check_option_names(o, results::straightness_kind);
  StraightnessOptions s;
  s.step_m = number_option(o, results::straightness_step_mm) * 1e-3;
  s.start_m = number_option(o, results::straightness_start_mm) * 1e-3;
  s.stations = static_cast<std::size_t>(integer_option(o, results::straightness_stations));
  if (s.stations == 1)
    throw std::invalid_argument("option stations = 1: a traverse needs at least 2 (0 = until the return)");
  s.passes = static_cast<std::size_t>(integer_option(o, results::straightness_passes));
  s.wait_for_return = string_option(o, results::straightness_start) == "return";
  s.return_gap_s = number_option(o, results::straightness_return_gap_s);
  s.min_dwell_s = number_option(o, results::straightness_min_dwell_s);
  s.max_hole_s = number_option(o, results::straightness_max_hole_s);
  s.settle_rad = number_option(o, results::straightness_settle_arcsec) * models::flatness::rad_per_arcsec;
  s.pitch_channel = string_option(o, results::straightness_pitch_channel);
  s.yaw_channel = string_option(o, results::straightness_yaw_channel);
  if (s.yaw_channel == s.pitch_channel)  // one reading taken for both planes' angles would be a wrong result
    throw std::invalid_argument("options pitch_channel and yaw_channel name the same channel \"" + s.pitch_channel +
                                "\": the pitch and the yaw are two readings (yaw_channel = \"\" for none)");
  s.axis = string_option(o, results::straightness_axis)[0] - 'x';
  // The channels' signs that make the file's angles slopes along the traversed axis (docs/conventions.md):
  // 0, the default, takes the axis' convention.
  for (const results::SessionOption* sign : {&results::straightness_pitch_sign, &results::straightness_yaw_sign}) {
    const bool pitch = sign == &results::straightness_pitch_sign;
    double v = number_option(o, *sign);
    if (v == 0.0) v = pitch ? models::flatness::traverse_pitch_sign(s.axis) : models::flatness::traverse_yaw_sign(s.axis);
    if (v != 1.0 && v != -1.0)
      throw std::invalid_argument("option " + std::string(sign->name) + " must be 1 or -1 (0: the axis' convention)");
    (pitch ? s.pitch_sign : s.yaw_sign) = v;
  }
  s.model.instrument.u_override_rad =
      number_option(o, results::straightness_angle_u_arcsec) * models::flatness::rad_per_arcsec;
  s.model.max_order = static_cast<int>(integer_option(o, results::straightness_max_order));
  return s;
}

int channel_index(const drivers::Driver& device, const std::string& name) {
  const auto& ch = device.channels();
  for (std::size_t i = 0; i < ch.size(); ++i) {
    if (ch[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

class StraightnessSession : public Session {
 public:
  StraightnessSession(StraightnessOptions options, const drivers::Driver& device)
      : o_(std::move(options)), device_(device.name()) {
    pitch_ = channel_index(device, o_.pitch_channel);
    if (pitch_ < 0)
      throw std::invalid_argument("device " + device.name() + " has no channel \"" + o_.pitch_channel + "\"");
    if (!o_.yaw_channel.empty()) {
      yaw_ = channel_index(device, o_.yaw_channel);
      if (yaw_ < 0)
        throw std::invalid_argument("device " + device.name() + " has no channel \"" + o_.yaw_channel + "\"");
    }
    collecting_ = !o_.wait_for_return;
  }

  void on_samples(std::span<const Sample> samples) override {
    for (const Sample& s : samples) {
      if (done_) return;
      const double t = static_cast<double>(s.t_mono_ns) * 1e-9;
      // Readings missing for longer than max_hole_s (link timeouts, a reconnect) could hide a move or
      // a whole station: what was measured can no longer be placed, so the traverse starts again.
      const bool hole = (have_last_ && t - last_t_ > o_.max_hole_s) || (s.flags & sample_after_gap);
      last_t_ = t;
      have_last_ = true;
      if (hole) on_hole(t);
      const bool valid = !(s.flags & (sample_out_of_range | sample_no_signal)) &&
                         s.value_count > static_cast<std::uint32_t>(std::max(pitch_, yaw_)) &&
                         std::isfinite(s.value[static_cast<std::size_t>(pitch_)]) &&
                         (yaw_ < 0 || std::isfinite(s.value[static_cast<std::size_t>(yaw_)]));
      if (!valid) {
        if (!in_gap_) {
          in_gap_ = true;
          gap_tainted_ = hole;
          gap_from_ = have_valid_ ? last_valid_t_ : t;
          close_dwell();
        }
        // The reflector is being carried back: a traverse of open length ends here already.
        if (collecting_ && o_.stations == 0 && pitch_rad_.size() >= 2 && t - gap_from_ >= o_.return_gap_s) done_ = true;
        continue;
      }
      if (in_gap_) {
        in_gap_ = false;
        if (t - gap_from_ >= o_.return_gap_s && !gap_tainted_) on_return();
        if (done_) return;
      }
      const double pitch = s.value[static_cast<std::size_t>(pitch_)];
      const double yaw = yaw_ >= 0 ? s.value[static_cast<std::size_t>(yaw_)] : 0.0;
      const auto n = static_cast<double>(dwell_n_);
      if (dwell_n_ > 0 &&
          (std::abs(pitch - dwell_pitch_ / n) > o_.settle_rad || std::abs(yaw - dwell_yaw_ / n) > o_.settle_rad)) {
        close_dwell();  // the reflector moved without losing the beam
      }
      if (dwell_n_ == 0) dwell_t0_ = t;
      dwell_t1_ = t;
      dwell_pitch_ += pitch;
      dwell_yaw_ += yaw;
      ++dwell_n_;
      last_valid_t_ = t;
      have_valid_ = true;
    }
  }

  [[nodiscard]] bool complete() const override { return done_; }

  [[nodiscard]] std::string progress() const override {
    std::ostringstream p;
    if (!collecting_) {
      p << "waiting for the reflector to be carried back to the start (beam break of " << o_.return_gap_s << " s)";
    } else {
      p << pitch_rad_.size();
      if (o_.stations > 0) p << "/" << o_.stations * o_.passes;
      p << " stations";
    }
    if (!note_.empty()) p << "; " << note_;
    return p.str();
  }

  // The stations still to measure at the pace of those measured so far (from one station's start to the next);
  // nullopt for a traverse of open length and before its second station.
  [[nodiscard]] std::optional<double> time_left_s() const override {
    const std::size_t n = pitch_rad_.size();
    if (!collecting_ || o_.stations == 0 || n < 2) return std::nullopt;
    return (last_station_t_ - first_station_t_) / static_cast<double>(n - 1) *
           static_cast<double>(o_.stations * o_.passes - n);
  }

  results::Params identify() override {
    if (!done_) close_dwell();  // stopped: the stations measured so far
    if (pitch_rad_.size() < 2) {
      throw std::runtime_error(
          "traverse of " + std::to_string(pitch_rad_.size()) + " station(s); at least 2 are needed" +
          (collecting_ ? "" : " (no return of the reflector was seen: option start=now starts at once)"));
    }
    if (pitch_rad_.size() % o_.passes != 0 || pitch_rad_.size() / o_.passes < 2) {
      throw std::runtime_error(std::to_string(pitch_rad_.size()) + " stations do not make " +
                               std::to_string(o_.passes) +
                               " passes of 2 or more stations each (option passes: the passes the traverse "
                               "program runs; " +
                               (done_ ? "the program ran a different number)" : "stopped within a pass)"));
    }
    text_ = traverse_text();
    const models::flatness::AngleTraverse tr =
        models::flatness::parse_angle_traverse(text_, "traverse", o_.model.instrument);
    const models::flatness::StraightnessResult r = models::flatness::identify_straightness(tr, o_.model);
    results::TraverseModelResult result = models::flatness::traverse_model_result(r);
    result.source.reset();  // the session's file is its derived file, named in the header
    results::Params p;
    p.axis = std::string(1, "xyz"[o_.axis]);  // the daemon keeps the newest PARAMS per kind and axis
    p.model = result.model;
    const std::string_view group = results::horizontal_straightness.group;
    results::FigureGroup& g = p.group_named(group);
    auto add = [&](const std::string& plane, const models::flatness::StraightnessProfile& profile) {
      for (const auto& [name, line] :
           {std::pair{"end_point", &profile.end_point}, std::pair{"least_squares", &profile.least_squares},
            std::pair{"minimum_zone", &profile.minimum_zone}}) {
        g.figures.push_back(results::figure(plane + "_" + name + "_um", line->straightness_m * 1e6,
                                            line->u_straightness_m * 1e6, group));
      }
    };
    add("vertical", r.vertical);
    if (r.horizontal) add("horizontal", *r.horizontal);
    p.traverse = results::TraverseSetup{r.readings, o_.passes, r.step_m * 1e3, o_.start_m * 1e3, p.axis};
    if (!done_) {  // stopped before the count or the return
      p.incomplete = "stopped after " + std::to_string(pitch_rad_.size()) +
                     (o_.stations > 0 ? " of " + std::to_string(o_.stations * o_.passes) : std::string()) + " stations";
    }
    p.traverse_result = std::move(result);
    return p;
  }

  [[nodiscard]] std::map<std::string, std::string> metadata() const override {
    return {{"axis", std::string(1, "xyz"[o_.axis])},
            {"step_mm", shortest(o_.step_m * 1e3)},
            {"passes", std::to_string(o_.passes)},
            {"start_mm", shortest(o_.start_m * 1e3)},
            {"pitch_channel", o_.pitch_channel + (o_.pitch_sign < 0 ? " (negated)" : "")},
            {"yaw_channel", o_.yaw_channel.empty() ? "none" : o_.yaw_channel + (o_.yaw_sign < 0 ? " (negated)" : "")}};
  }

  std::vector<std::string> write_derived(const std::string& dir, const std::string& base_name) override {
    return write_derived_text(dir, base_name, "angles.csv", text_);
  }

  // `guideway explain --model traverse` of the derived file's text, as offline: what the straightness
  // polynomial common to the passes leaves, named from the traverse library (docs/explain.md, "Traverses").
  std::optional<results::Explanation> explain() override {
    if (text_.empty()) return std::nullopt;
    const auto passes = models::explain::parse_traverse_passes(text_, "traverse");
    try {
      return models::explain::explanation_of(models::explain::explain_traverses(passes, explain_options(*this)));
    } catch (const std::invalid_argument& e) {  // too few readings in a pass: said, not claimed
      const std::string why = e.what();
      return results::not_analysed(std::string(results::straightness_kind.name),
                                   why.starts_with("explain: ") ? why.substr(9) : why);
    }
  }

 private:
  void close_dwell() {
    const std::size_t n = dwell_n_;
    const double t0 = dwell_t0_, t1 = dwell_t1_;
    const double pitch = n ? dwell_pitch_ / static_cast<double>(n) : 0.0,
                 yaw = n ? dwell_yaw_ / static_cast<double>(n) : 0.0;
    dwell_n_ = 0;
    dwell_pitch_ = dwell_yaw_ = 0.0;
    if (n == 0 || !collecting_ || done_) return;
    if (t1 - t0 < o_.min_dwell_s) return;  // passing through, not resting on a station
    pitch_rad_.push_back(o_.pitch_sign * pitch);
    yaw_rad_.push_back(o_.yaw_sign * yaw);
    station_t_.push_back(0.5 * (t0 + t1));  // the reading is the dwell's mean
    (pitch_rad_.size() == 1 ? first_station_t_ : last_station_t_) = t0;
    if (o_.stations > 0 && pitch_rad_.size() >= o_.stations * o_.passes) done_ = true;
  }

  void on_hole(double t) {
    if (in_gap_) gap_tainted_ = true;  // not provably a return
    dwell_n_ = 0;                      // the dwell under way may merge two stations
    dwell_pitch_ = dwell_yaw_ = 0.0;
    if (!collecting_ || done_) return;
    std::ostringstream m;
    m << "no reading for " << t - last_valid_t_ << " s after station " << pitch_rad_.size()
      << ": waiting for the next traverse";
    note_ = m.str();
    collecting_ = false;
    clear_stations();
  }

  // The reflector went back to the start.
  void on_return() {
    if (!collecting_) {
      collecting_ = true;
      note_.clear();
      return;
    }
    if (o_.stations == 0 && pitch_rad_.size() >= 2) {
      done_ = true;
      return;
    }
    if (!pitch_rad_.empty()) {
      note_ = "a traverse of " + std::to_string(pitch_rad_.size()) + " station(s) ended early; starting again";
    }
    clear_stations();
  }

  void clear_stations() {
    pitch_rad_.clear();
    yaw_rad_.clear();
    station_t_.clear();
  }

  // The traverse file of docs/formats.md: angles in arc-seconds, written so they read back exactly; with the
  // time of each reading (since the first) and its pass, forward passes odd, returns even.
  [[nodiscard]] std::string traverse_text() const {
    // With the axis, x_mm is the carriage's position along it (where the map places the reading).
    std::string t = "# step_mm = " + shortest(o_.step_m * 1e3) + "\n# axis = " + std::string(1, "xyz"[o_.axis]) +
                    "\n# device = " + device_ + "\n# source = guidewayd straightness session\n";
    t += yaw_ >= 0 ? "x_mm,pitch_arcsec,yaw_arcsec,t_s,pass\n" : "x_mm,pitch_arcsec,t_s,pass\n";
    const std::size_t per_pass = pitch_rad_.size() / o_.passes;
    for (std::size_t k = 0; k < pitch_rad_.size(); ++k) {
      const std::size_t pass = k / per_pass, i = k % per_pass;
      const std::size_t station = pass % 2 == 0 ? i : per_pass - 1 - i;
      t += shortest((o_.start_m + static_cast<double>(station) * o_.step_m) * 1e3) + "," +
           shortest(pitch_rad_[k] / models::flatness::rad_per_arcsec);
      if (yaw_ >= 0) t += "," + shortest(yaw_rad_[k] / models::flatness::rad_per_arcsec);
      t += "," + shortest(station_t_[k] - station_t_[0]) + "," + std::to_string(pass + 1) + "\n";
    }
    return t;
  }

  StraightnessOptions o_;
  std::string device_;
  int pitch_ = -1, yaw_ = -1;
  bool collecting_ = false;
  bool done_ = false;
  bool in_gap_ = false;
  bool gap_tainted_ = false;  // a hole inside the gap: its length proves nothing
  double last_t_ = 0.0;
  bool have_last_ = false;
  double gap_from_ = 0.0;
  double last_valid_t_ = 0.0;
  bool have_valid_ = false;
  std::size_t dwell_n_ = 0;
  double dwell_t0_ = 0.0, dwell_t1_ = 0.0, dwell_pitch_ = 0.0, dwell_yaw_ = 0.0;
  std::vector<double> pitch_rad_, yaw_rad_;
  std::vector<double> station_t_;                        // mid-dwell time of each station, s
  double first_station_t_ = 0.0, last_station_t_ = 0.0;  // the first and the last station's start (time_left_s)
  std::string note_;
  std::string text_;
};

// A recording made before the passes option (no "passes" in its header) ran one forward pass of the
// 50 mm step of its day.
nlohmann::json recorded_options(nlohmann::json options, const std::map<std::string, std::string>& header) {
  if (header.count(std::string(results::straightness_passes.name)) > 0 || !options.is_object()) return options;
  const std::string passes(results::straightness_passes.name), step(results::straightness_step_mm.name);
  if (!options.contains(passes)) options[passes] = 1;
  if (!options.contains(step)) options[step] = 50.0;
  return options;
}

}  // namespace

SessionKind straightness_session_kind() {
  return {std::string(results::straightness_kind.name),
          results::description(results::straightness_kind),
          {"autocollimator-serial"},
          [](const SessionRequest& r, const drivers::Driver& device) -> std::unique_ptr<Session> {
            return std::make_unique<StraightnessSession>(parse_options(r.options), device);
          },
          &recorded_options};
}

}  // namespace guideway::sessions
