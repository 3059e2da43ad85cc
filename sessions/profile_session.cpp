// The "profile" session (profile_session.hpp): one flagged profilometer traverse, its straightness and wavelet MRA.
#include "sessions/profile_session.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/number_format.hpp"
#include "drivers/profilometer/profile_stream.hpp"
#include "dsp/denoise.hpp"
#include "dsp/series.hpp"
#include "dsp/wavelet.hpp"
#include "formats/profile_files.hpp"
#include "models/explain/explanation.hpp"
#include "models/explain/profile_explain.hpp"
#include "models/flatness/straightness.hpp"
#include "results/parameters.hpp"
#include "sessions/explain_options.hpp"
#include "sessions/session_support.hpp"

namespace guideway::sessions {

namespace {

// Least-squares line through the valid points; returns the deviations (NaN where z is NaN).
std::vector<double> line_deviations(const std::vector<double>& x, const std::vector<double>& z) {
  double n = 0, sx = 0, sz = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (std::isnan(z[i])) continue;
    n += 1;
    sx += x[i];
    sz += z[i];
  }
  const double mx = sx / n, mz = sz / n;
  double sxx = 0, sxz = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (std::isnan(z[i])) continue;
    sxx += (x[i] - mx) * (x[i] - mx);
    sxz += (x[i] - mx) * (z[i] - mz);
  }
  const double slope = sxx > 0 ? sxz / sxx : 0.0;
  std::vector<double> d(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) d[i] = z[i] - (mz + slope * (x[i] - mx));
  return d;
}

}  // namespace

results::Params evaluate_profile(const formats::Profile& profile, const ProfileEvaluationOptions& options) {
  const std::size_t n = profile.x_m.size();
  const dsp::Wavelet wavelet(options.wavelet);
  const dsp::Mode mode = dsp::parse_mode(options.mode);
  if (options.level < 1) throw std::invalid_argument("wavelet level must be at least 1");
  if (n < (std::size_t{1} << options.level) || n < 3) {
    throw std::invalid_argument("a profile of " + std::to_string(n) + " points is too short for " +
                                std::to_string(options.level) + " wavelet levels");
  }
  const auto spacing = profile.spacing_m();
  if (!spacing) throw std::invalid_argument("the profile's points are not equally spaced");
  // Work in the file's units (mm, um) so the numbers are those a reader of the derived file sees.
  std::vector<double> x_mm(n), z_um(n);
  std::size_t invalid = 0;
  for (std::size_t i = 0; i < n; ++i) {
    x_mm[i] = profile.x_m[i] * 1e3;
    z_um[i] = profile.z_m[i] * 1e6;
    invalid += std::isnan(z_um[i]) ? 1 : 0;
  }
  if (invalid * 100 > n) {
    throw std::invalid_argument(std::to_string(invalid) + " of " + std::to_string(n) +
                                " points are invalid (over 1 %)");
  }
  const std::vector<double> filled = dsp::fill_gaps_linear(z_um);  // the wavelet transform needs every point

  const std::vector<double> dev = line_deviations(x_mm, z_um);
  std::vector<double> vx, vz;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isnan(z_um[i])) continue;
    vx.push_back(x_mm[i]);
    vz.push_back(z_um[i]);
  }
  const double min_zone_um = models::flatness::minimum_zone(vx, vz).width;
  const auto coeffs = dsp::wavedec(filled, wavelet, mode, options.level);
  const double sigma_um = dsp::mad_sigma(coeffs.back());
  const auto components = dsp::mra(filled, wavelet, mode, options.level);  // [A_J, D_J, ..., D_1]
  const double form_um = dsp::peak_to_valley(line_deviations(x_mm, components[0]));

  // Uncertainties from the white noise sigma (first order): a peak to valley is the difference of two
  // points; the approximation A_J keeps 1 / 2^J of the noise variance. The extremes of noisy points
  // are selected, so the peak-to-valley values are biased upwards by the noise (not corrected here).
  const double level_scale = std::pow(2.0, -0.5 * options.level);
  const double n1 = static_cast<double>(coeffs.back().size());
  results::Params p;
  p.model = "profile/straightness+wavelet";
  // The headline figures named by their catalogue entries (results/parameters.hpp), where the fleet reads them.
  const std::string_view group = results::profile_straightness.group;
  results::FigureGroup& g = p.group_named(group);
  const auto add = [&](std::string name, double value, double u) {
    g.figures.push_back(results::figure(std::move(name), value, u, group));
  };
  add(results::name(results::profile_straightness), dsp::peak_to_valley(dev), std::sqrt(2.0) * sigma_um);
  add("straightness_min_zone_um", min_zone_um, std::sqrt(2.0) * sigma_um);
  add(results::name(results::form_straightness), form_um, std::sqrt(2.0) * sigma_um * level_scale);
  add("noise_um", sigma_um, sigma_um * std::sqrt(1.36 / n1));  // MAD: var ~ 1.36 s^2 / n
  // Per band: the rms of its signal-domain component, the part white noise of level sigma explains
  // (an orthogonal transform spreads the noise energy over the coefficients: n_b sigma^2 in band b),
  // and the rest, the band's signal. The dominant detail band is the one with the most signal.
  results::WaveletSummary& wavelet_summary = p.wavelet.emplace();
  wavelet_summary.wavelet = options.wavelet;
  wavelet_summary.mode = options.mode;
  wavelet_summary.level = static_cast<std::size_t>(options.level);
  const double dx_mm = *spacing * 1e3;
  std::size_t dominant = 1;
  double best = -1;
  for (std::size_t b = 0; b < components.size(); ++b) {
    // Band b: the approximation A_J, then details D_J .. D_1 (PyWavelets' order).
    const int lev = b == 0 ? options.level : options.level + 1 - static_cast<int>(b);
    results::WaveletBand band;
    band.band = b == 0 ? "a" + std::to_string(lev) : "d" + std::to_string(lev);
    band.coefficients = coeffs[b].size();
    if (b == 0) {
      band.form_um = form_um;
      band.wavelength_min_mm = dx_mm * std::pow(2.0, lev + 1);
    } else {
      const double r = dsp::rms(components[b]);
      const double noise = sigma_um * std::sqrt(static_cast<double>(coeffs[b].size()) / static_cast<double>(n));
      const double signal = std::sqrt(std::max(0.0, r * r - noise * noise));
      band.rms_um = r;
      band.noise_rms_um = noise;
      band.signal_rms_um = signal;
      band.wavelength_min_mm = dx_mm * std::pow(2.0, lev);
      band.wavelength_max_mm = dx_mm * std::pow(2.0, lev + 1);
      if (signal > best) {
        best = signal;
        dominant = b;
      }
    }
    wavelet_summary.bands.push_back(std::move(band));
  }
  wavelet_summary.dominant_detail = wavelet_summary.bands[dominant].band;  // level >= 1: band 1 is a detail
  p.points = results::ProfilePoints{n, invalid, *spacing * 1e6, x_mm.back() - x_mm.front()};
  return p;
}

namespace {

struct ProfileOptions {
  ProfileEvaluationOptions eval;
  double feed_mm_per_min = 0;  // 0: not given
  double spindle_rpm = 0;
};

ProfileOptions parse_options(const nlohmann::json& o) {
  check_option_names(o, results::profile_kind);
  ProfileOptions p;
  p.eval.wavelet = string_option(o, results::profile_wavelet);
  p.eval.mode = string_option(o, results::profile_mode);
  p.eval.level = static_cast<int>(integer_option(o, results::profile_level));
  try {
    (void)dsp::Wavelet(p.eval.wavelet);
    (void)dsp::parse_mode(p.eval.mode);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("option wavelet/mode: ") + e.what());
  }
  p.feed_mm_per_min = number_option(o, results::profile_feed_mm_per_min);
  p.spindle_rpm = number_option(o, results::profile_spindle_rpm);
  return p;
}

class ProfileSession : public Session {
 public:
  ProfileSession(ProfileOptions options, const drivers::Driver& device)
      : o_(std::move(options)), device_(device.name()) {
    const auto& ch = device.channels();
    for (std::size_t i = 0; i < ch.size(); ++i) {
      if (ch[i].name == "x") x_ = static_cast<int>(i);
      if (ch[i].name == "z") z_ = static_cast<int>(i);
      if (ch[i].name == "profile") id_ = static_cast<int>(i);
    }
    if (x_ < 0 || z_ < 0 || id_ < 0) {
      throw std::invalid_argument("device " + device.name() + " needs x, z and profile channels");
    }
  }

  void on_samples(std::span<const Sample> samples) override {
    const auto needed = static_cast<std::uint32_t>(std::max({x_, z_, id_}) + 1);
    for (const Sample& s : samples) {
      if (done_) return;
      if (s.value_count < needed) continue;
      const double id = s.value[static_cast<std::size_t>(id_)];
      if (s.flags & drivers::profilometer::sample_profile_start) {
        if (collecting_ && !x_m_.empty()) note_ = "profile " + shortest(profile_id_) + " was cut short; took the next";
        collecting_ = true;
        profile_id_ = id;
        x_m_.clear();
        z_m_.clear();
      } else if (!collecting_) {
        continue;
      } else if ((s.flags & sample_after_gap) || id != profile_id_) {
        note_ = "profile " + shortest(profile_id_) + " was interrupted; waiting for the next";
        collecting_ = false;
        continue;
      }
      x_m_.push_back(s.value[static_cast<std::size_t>(x_)]);
      // Over-range points arrive as NaN with sample_out_of_range: kept as invalid points.
      z_m_.push_back(s.flags & sample_out_of_range ? std::nan("") : s.value[static_cast<std::size_t>(z_)]);
      if (s.flags & drivers::profilometer::sample_profile_end) done_ = true;
    }
  }

  [[nodiscard]] bool complete() const override { return done_; }

  [[nodiscard]] std::string progress() const override {
    std::ostringstream p;
    if (!collecting_) {
      p << "waiting for the start of a profile";
    } else {
      p << "profile " << profile_id_ << ": " << x_m_.size() << " points" << (done_ ? ", complete" : "");
    }
    if (!note_.empty()) p << "; " << note_;
    return p.str();
  }

  results::Params identify() override {
    if (!done_) {
      throw std::runtime_error(collecting_ ? "stopped before the end of profile " + shortest(profile_id_) + " (" +
                                                 std::to_string(x_m_.size()) + " points)"
                                           : "no profile was started" + (note_.empty() ? "" : " (" + note_ + ")"));
    }
    formats::Profile p;
    p.x_m = x_m_;
    p.z_m = z_m_;
    p.metadata = {{"source", "guidewayd profile session"}, {"device", device_}, {"profile", shortest(profile_id_)}};
    if (o_.feed_mm_per_min > 0) p.metadata.emplace_back("feed_mm_per_min", shortest(o_.feed_mm_per_min));
    if (o_.spindle_rpm > 0) p.metadata.emplace_back("spindle_rpm", shortest(o_.spindle_rpm));
    text_ = formats::format_profile_csv(p);
    const formats::Profile read = formats::parse_profile_csv(text_, "profile");
    try {
      results::Params params = evaluate_profile(read, o_.eval);
      params.profile_id = static_cast<std::uint64_t>(profile_id_);
      return params;
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(e.what());
    }
  }

  [[nodiscard]] std::map<std::string, std::string> metadata() const override {
    return {{"wavelet", o_.eval.wavelet}, {"level", std::to_string(o_.eval.level)}, {"mode", o_.eval.mode}};
  }

  std::vector<std::string> write_derived(const std::string& dir, const std::string& base_name) override {
    return write_derived_text(dir, base_name, "profile.csv", text_);
  }

  // `guideway explain --model straightness` of the profile file's text, as offline on the derived file: base =
  // offset + cubic in x; the candidates (feed marks, spindle axial run-out, thermal drift, tool wear, ...) need
  // the time of each point and the feed per revolution, so feed and spindle speed must be given.
  std::optional<results::Explanation> explain() override {
    if (!(o_.feed_mm_per_min > 0) || !(o_.spindle_rpm > 0))
      return results::not_analysed("straightness",
                                   "the session was started without feed_mm_per_min and spindle_rpm, "
                                   "which place each point in time and give the feed per revolution");
    try {
      const models::explain::ProfileRun run =
          models::explain::profile_run(formats::parse_profile_csv(text_, "profile"), "profile");
      return models::explain::explanation_of(
          models::explain::explain_profiles({run}, "straightness", nullptr, explain_options(*this)));
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(e.what());
    }
  }

 private:
  ProfileOptions o_;
  std::string device_;
  int x_ = -1, z_ = -1, id_ = -1;
  bool collecting_ = false;
  bool done_ = false;
  double profile_id_ = 0;
  std::vector<double> x_m_, z_m_;
  std::string note_;
  std::string text_;
};

}  // namespace

SessionKind profile_session_kind() {
  return {std::string(results::profile_kind.name),
          results::description(results::profile_kind),
          {"profilometer-tcp"},
          [](const SessionRequest& r, const drivers::Driver& device) -> std::unique_ptr<Session> {
            return std::make_unique<ProfileSession>(parse_options(r.options), device);
          },
          {}};  // no recorded_options: a recording of this kind replays with its recorded options
}

}  // namespace guideway::sessions
