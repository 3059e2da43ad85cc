// The "runout" session (runout_session.hpp): spindle revolutions of the micrometer, run-out and error motion.
#include "sessions/runout_session.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/number_format.hpp"
#include "models/explain/explanation.hpp"
#include "models/explain/runout_explain.hpp"
#include "models/flatness/error_motion.hpp"
#include "models/flatness/json.hpp"
#include "models/flatness/runout.hpp"
#include "results/parameters.hpp"
#include "sessions/explain_options.hpp"
#include "sessions/session_support.hpp"

namespace guideway::sessions {

namespace {

struct RunoutOptions {
  double plate_diameter_mm = 1000.0;
  double parallelism_um = 2.5;
  double parallelism_u_um = 0.0;
  double travel_mm = 600.0;
  double rpm = 60.0;
  double revolutions = 20.0;
  std::string channel = "displacement";
  double artifact_turned_deg = 0.0;
};

RunoutOptions parse_options(const nlohmann::json& o) {
  check_option_names(o, results::runout_kind);
  RunoutOptions r;
  r.plate_diameter_mm = number_option(o, results::runout_plate_diameter_mm);
  r.parallelism_um = number_option(o, results::runout_parallelism_um);
  r.parallelism_u_um = number_option(o, results::runout_parallelism_u_um);
  r.travel_mm = number_option(o, results::runout_travel_mm);
  r.rpm = number_option(o, results::runout_rpm);
  r.revolutions = number_option(o, results::runout_revolutions);
  r.channel = string_option(o, results::runout_channel);
  r.artifact_turned_deg = number_option(o, results::runout_artifact_turned_deg);
  return r;
}

class RunoutSession : public Session {
 public:
  RunoutSession(RunoutOptions options, const drivers::Driver& device) : o_(std::move(options)), device_(device.name()) {
    const auto& ch = device.channels();
    for (std::size_t i = 0; i < ch.size(); ++i) {
      if (ch[i].name == o_.channel) channel_ = static_cast<int>(i);
    }
    if (channel_ < 0) throw std::invalid_argument("device " + device.name() + " has no channel \"" + o_.channel + "\"");
    duration_s_ = o_.revolutions * 60.0 / o_.rpm;
  }

  void on_samples(std::span<const Sample> samples) override {
    for (const Sample& s : samples) {
      if (done_) return;
      if (s.flags & (sample_out_of_range | sample_no_signal) || s.value_count <= static_cast<std::uint32_t>(channel_)) {
        ++skipped_;
        continue;
      }
      const double z = s.value[static_cast<std::size_t>(channel_)];
      if (!std::isfinite(z)) {
        ++skipped_;
        continue;
      }
      if (t0_ns_ < 0) t0_ns_ = s.t_mono_ns;
      const double t = static_cast<double>(s.t_mono_ns - t0_ns_) * 1e-9;
      // The reading at or past the last turn's end is kept: it closes that turn, so a late or missed
      // reading before it (a loaded machine) cannot leave the record a step short of its revolutions.
      angle_deg_.push_back(t * o_.rpm * 6.0);
      runout_um_.push_back(z * 1e6);
      if (t >= duration_s_) {
        done_ = true;
        return;
      }
    }
  }

  [[nodiscard]] bool complete() const override { return done_; }

  [[nodiscard]] std::string progress() const override {
    std::ostringstream p;
    const double deg = angle_deg_.empty() ? 0.0 : angle_deg_.back();
    p << static_cast<int>(deg) << " of " << static_cast<int>(o_.revolutions * 360.0) << " deg";
    if (skipped_) p << " (" << skipped_ << " invalid readings skipped)";
    return p.str();
  }

  // The revolutions still to turn at the test's speed (all of them before the first reading).
  [[nodiscard]] std::optional<double> time_left_s() const override {
    const double turned_s = angle_deg_.empty() ? 0.0 : angle_deg_.back() / (o_.rpm * 6.0);
    return std::max(0.0, duration_s_ - turned_s);
  }

  results::Params identify() override {
    if (angle_deg_.empty()) throw std::runtime_error("no valid micrometer reading was received");
    text_ = revolution_text();
    const models::flatness::RunoutRevolution rev = models::flatness::parse_runout_revolution(text_, "revolution");
    const models::flatness::RunoutResult r = models::flatness::identify_runout(rev);
    results::RunoutModelResult result = models::flatness::runout_model_result(rev);
    results::Params p;
    p.model = result.model;
    // The headline figures named by their catalogue entries (results/parameters.hpp), where the fleet reads them.
    const std::string_view group = results::runout_squareness.group;
    results::FigureGroup& g = p.group_named(group);
    const auto add = [&](std::string name, double value, double u) {
      g.figures.push_back(results::figure(std::move(name), value, u, group));
    };
    add(results::name(results::runout), r.runout_m * 1e6, r.u_runout_m * 1e6);
    add("once_per_rev_amplitude_um", r.amplitude_m * 1e6, r.u_amplitude_m * 1e6);
    add(results::name(results::runout_squareness), r.deflection_rad * 1e6, r.u_deflection_rad * 1e6);
    if (r.squareness_amplitude_m)
      add("squareness_amplitude_um", *r.squareness_amplitude_m * 1e6, *r.u_squareness_amplitude_m * 1e6);
    results::RunoutRevolution& revolution = p.revolution.emplace();
    revolution.samples = r.samples;
    revolution.rpm = o_.rpm;
    revolution.covered_deg = angle_deg_.back();
    if (const auto& motion = result.error_motion) {
      // ISO 230-7 values: peaks-to-valleys of the record as measured (no uncertainty of their own).
      const std::string_view em_group = results::total_error_motion.group;
      results::FigureGroup& em = p.group_named(em_group);
      for (const auto& [entry, value] : {std::pair{&results::total_error_motion, motion->total_um},
                                         std::pair{&results::synchronous_error_motion, motion->synchronous_um},
                                         std::pair{&results::asynchronous_error_motion, motion->asynchronous_um},
                                         std::pair{&results::fundamental_error_motion, motion->fundamental_um}})
        em.figures.push_back(results::figure(results::name(*entry), value, std::nullopt, em_group));
      revolution.revolutions = motion->revolutions;
    }
    if (!done_) p.incomplete = shortest(angle_deg_.back()) + " of " + shortest(o_.revolutions * 360.0) + " deg";
    p.runout_result = std::move(result);
    return p;
  }

  [[nodiscard]] std::map<std::string, std::string> metadata() const override {
    std::map<std::string, std::string> m{{"plate_diameter_mm", shortest(o_.plate_diameter_mm)},
                                         {"parallelism_um", shortest(o_.parallelism_um)},
                                         {"travel_mm", shortest(o_.travel_mm)},
                                         {"rpm", shortest(o_.rpm)},
                                         {"revolutions", shortest(o_.revolutions)}};
    if (o_.artifact_turned_deg != 0) m["artifact_turned_deg"] = shortest(o_.artifact_turned_deg);
    return m;
  }

  std::vector<std::string> write_derived(const std::string& dir, const std::string& base_name) override {
    return write_derived_text(dir, base_name, "runout.csv", text_);
  }

  // `guideway explain --model runout` of the derived file's text, as offline: what the once-per-revolution
  // base leaves, named from the spindle's library (docs/explain.md, "Run-out").
  std::optional<results::Explanation> explain() override {
    if (text_.empty()) return std::nullopt;
    const auto rev = models::flatness::parse_runout_revolution(text_, "revolution");
    if (models::flatness::whole_revolutions(rev.angle_rad) < 2)
      return results::not_analysed(std::string(results::runout_kind.name),
                                   "fewer than 2 whole revolutions recorded: what repeats every revolution cannot be "
                                   "told from what does not (record several, e.g. revolutions = 20)");
    return models::explain::explanation_of(
        models::explain::explain_runout({models::explain::runout_record(rev, o_.rpm)}, explain_options(*this)));
  }

 private:
  // The run-out file of docs/formats.md, written so it reads back exactly.
  [[nodiscard]] std::string revolution_text() const {
    std::string t = "# plate_diameter_mm = " + shortest(o_.plate_diameter_mm) +
                    "\n# parallelism_um = " + shortest(o_.parallelism_um) +
                    "\n# parallelism_u_um = " + shortest(o_.parallelism_u_um) + "\n";
    if (o_.travel_mm > 0) t += "# travel_mm = " + shortest(o_.travel_mm) + "\n";
    t += "# rpm = " + shortest(o_.rpm) + "\n# device = " + device_ + "\n# source = guidewayd runout session\n";
    // The angles come from time since the first reading (the micrometer reads no spindle angle).
    t += "# angle_zero = first_reading\n";
    if (o_.artifact_turned_deg != 0) t += "# artifact_turned_deg = " + shortest(o_.artifact_turned_deg) + "\n";
    t += "angle_deg,runout_um\n";
    for (std::size_t i = 0; i < angle_deg_.size(); ++i)
      t += shortest(angle_deg_[i]) + "," + shortest(runout_um_[i]) + "\n";
    return t;
  }

  RunoutOptions o_;
  std::string device_;
  int channel_ = -1;
  double duration_s_ = 0.0;
  std::int64_t t0_ns_ = -1;
  bool done_ = false;
  std::size_t skipped_ = 0;
  std::vector<double> angle_deg_, runout_um_;
  std::string text_;
};

}  // namespace

SessionKind runout_session_kind() {
  return {std::string(results::runout_kind.name),
          results::description(results::runout_kind),
          {"micrometer-modbus"},
          [](const SessionRequest& r, const drivers::Driver& device) -> std::unique_ptr<Session> {
            return std::make_unique<RunoutSession>(parse_options(r.options), device);
          },
          {}};  // no recorded_options: a recording of this kind replays with its recorded options
}

}  // namespace guideway::sessions
