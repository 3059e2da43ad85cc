// What a test on the virtual machine can find (machine_truth.hpp): per effect, the parameter it would report and its
// true value.
#include "simulators/scenarios/machine_truth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <map>
#include <numbers>
#include <stdexcept>

#include "core/number_format.hpp"
#include "results/parameters.hpp"

namespace guideway::simulators::scenarios {

namespace {

constexpr double um = 1e-6;

const char* letter(int axis) { return axis == 0 ? "x" : (axis == 1 ? "y" : "z"); }

// What the machine file holds of the ballbar diagnostics of the h = 0 runs (docs/conventions.md, "Ballbar
// diagnostics"): empty when no run is at h = 0 (the diagnostics are then not fitted).
std::vector<TruthItem> diagnostics_truth(const machine::MachineConfig& m, const std::string& plane, int a, int b,
                                         const std::vector<TruthRun>& runs) {
  double radius_m = 0, shrink_a = 0, shrink_b = 0;
  int flat = 0;
  for (const auto& r : runs) {
    if (r.height_m != 0 || r.radius_m <= 0) continue;
    // A position loop of lag tau shortens the traced radius by r (omega tau)^2 / 2: a scale of both axes.
    const double omega = r.feed_m_per_s / r.radius_m;
    shrink_a += 0.5 * std::pow(omega * m.axis[static_cast<std::size_t>(a)].servo_lag_s, 2);
    shrink_b += 0.5 * std::pow(omega * m.axis[static_cast<std::size_t>(b)].servo_lag_s, 2);
    if (flat++ == 0) radius_m = r.radius_m;
  }
  std::vector<TruthItem> out;
  if (flat == 0) return out;
  shrink_a /= flat;
  shrink_b /= flat;
  const std::array<int, 2> ab{a, b};
  for (int k = 0; k < 2; ++k)
    out.push_back({"centre offset", results::name(results::center_offset, plane, k),
                   m.dbb.center_offset[static_cast<std::size_t>(ab[static_cast<std::size_t>(k)])] / um, ""});
  const double square = a == 0 && b == 1 ? m.squareness.xy : (a == 0 ? m.squareness.xz : m.squareness.yz);
  out.push_back({"squareness", results::name(results::squareness), square * 1e6, ""});
  const auto lag_note = [&](double shrink) {
    return shrink * 1e6 < 0.05 ? std::string()
                               : "the file's scale less the servo lag's " + printf_number("%.3g ppm", shrink * 1e6) +
                                     ": the circle shrinks by r (omega tau)^2 / 2";
  };
  const double scale_a = m.axis[static_cast<std::size_t>(a)].scale, scale_b = m.axis[static_cast<std::size_t>(b)].scale;
  out.push_back({"scale", results::name(results::scale_mismatch), (scale_a - shrink_a - scale_b + shrink_b) * 1e6,
                 std::abs(shrink_a - shrink_b) * 1e6 < 0.05 ? "" : lag_note(shrink_a - shrink_b)});
  out.push_back({"scale", results::name(results::scale, plane, 0), (scale_a - shrink_a) * 1e6, lag_note(shrink_a)});
  out.push_back({"scale", results::name(results::scale, plane, 1), (scale_b - shrink_b) * 1e6, lag_note(shrink_b)});
  // The bow over the diameter: the quadratic coefficient of the axis' straightness across the plane, times r^2.
  for (int k = 0; k < 2; ++k) {
    const auto& poly = m.axis[static_cast<std::size_t>(ab[static_cast<std::size_t>(k)])]
                           .translation[static_cast<std::size_t>(ab[static_cast<std::size_t>(1 - k)])];
    const double c2 = poly.c.size() > 2 ? poly.c[2] : 0.0;
    out.push_back({"straightness", results::name(results::straightness_bow, plane, k), c2 * radius_m * radius_m / um,
                   "its quadratic term at r = " + printf_number("%g mm", radius_m * 1e3)});
  }
  return out;
}

}  // namespace

MachineTruth dbb_truth(const machine::MachineConfig& m, const std::string& plane, const std::vector<TruthRun>& runs,
                       bool angles_from_encoders) {
  if (plane != "xy" && plane != "xz" && plane != "yz") throw std::invalid_argument("dbb_truth: plane " + plane);
  const int a = plane == "yz" ? 1 : 0;
  const int b = plane == "xy" ? 1 : 2;
  const int normal = 3 - a - b;
  const std::array<int, 2> in_plane{a, b};
  MachineTruth t;

  // The test: its length in machine time (the data arcs), its samples, directions, radii, heights.
  double duration_s = 0, samples = 0, max_lean = 0, slowest_rate = 1e300, longest_run_s = 0;
  bool ccw = false, cw = false;
  std::vector<double> radii;
  for (const auto& r : runs) {
    const double run_s = r.feed_m_per_s > 0 ? 2 * std::numbers::pi * r.radius_m / r.feed_m_per_s : 0.0;
    duration_s += run_s;
    longest_run_s = std::max(longest_run_s, run_s);
    samples += r.sample_rate_hz * run_s;
    if (r.sample_rate_hz > 0) slowest_rate = std::min(slowest_rate, r.sample_rate_hz);
    max_lean = std::max(max_lean, r.height_m / std::hypot(r.radius_m, r.height_m));
    (r.direction > 0 ? ccw : cw) = true;
    if (std::none_of(radii.begin(), radii.end(), [&](double x) { return std::abs(x - r.radius_m) < 1e-4; }))
      radii.push_back(r.radius_m);
  }
  const double noise_um = m.dbb.noise_m / um;
  // What N samples resolve: an effect whose signal is below 7 sigma / sqrt(N) in the reading is not
  // told from noise by the tests (the scenarios find 0.15 um at 0.4 um noise and 7200 samples).
  const double floor_um = samples > 0 ? 7 * noise_um / std::sqrt(samples) : 0.0;
  const auto add = [&](std::string effect, std::string parameter, double value, double signal_um, std::string note) {
    if (signal_um > 0 && signal_um < floor_um)
      note += (note.empty() ? "" : "; ") + printf_number("%.3g", signal_um) + " um in the reading, below the " + printf_number("%.2g", floor_um) +
              " um these samples resolve";
    t.findable.push_back({std::move(effect), std::move(parameter), value, std::move(note)});
  };
  const auto cannot = [&](std::string what, std::string why) { t.unobservable.push_back({std::move(what), std::move(why)}); };

  for (const int j : in_plane) {
    const auto& e = m.axis[static_cast<std::size_t>(j)];
    const std::string L = letter(j);
    if (e.backlash_m != 0)
      add("backlash", results::name_along(results::backlash, L), e.backlash_m / um, 0.5 * e.backlash_m / um, "");
    if (e.reversal_spike_m != 0)
      add("reversal_spike", results::name_along(results::reversal_spike, L), e.reversal_spike_m / um,
          e.reversal_spike_m / um, "decay " + printf_number("%g", e.reversal_spike_decay_s * 1e3) + " ms");
    if (e.lateral_play_m != 0)
      add("lateral_play", results::name_along(results::lateral_play, L), e.lateral_play_m / um,
          0.5 * e.lateral_play_m / um, "");
    if (e.stick_slip_m != 0)
      add("stick_slip", results::name_along(results::stick_slip, L), e.stick_slip_m / um, e.stick_slip_m / um,
          printf_number("%g Hz, ", e.stick_slip_hz) + printf_number("decay %g ms", e.stick_slip_decay_s * 1e3));
    if (e.cyclic_amplitude_m != 0) {
      const double p_mm = e.cyclic_period_m * 1e3;
      if (p_mm < 1.0 || p_mm > 40.0)
        cannot("cyclic error " + L + " " + printf_number("%g um", e.cyclic_amplitude_m / um) + printf_number(", lead %g mm", p_mm),
               "outside the leads the explanation searches (1-40 mm)");
      else
        add("cyclic_error", results::name_along(results::cyclic_error, L), e.cyclic_amplitude_m / um,
            e.cyclic_amplitude_m / um, "lead " + printf_number("%g mm", p_mm));
    }
    if (e.vibration_amplitude_m != 0) {
      const double f = e.vibration_frequency_hz;
      const std::string what = "vibration " + L + " " + printf_number("%g um", e.vibration_amplitude_m / um) + printf_number(" at %g Hz", f);
      if (slowest_rate < 1e300 && f > 0.4 * slowest_rate)
        cannot(what, "above 0.4 x the bar's sample rate (" + printf_number("%g Hz", slowest_rate) + "): aliased, not searched");
      else if (longest_run_s > 0 && f < 4 / longest_run_s)
        cannot(what, "slower than 4 periods per run: a drift or Lai's base absorbs it");
      else
        add("vibration", results::name_along(results::vibration, L), e.vibration_amplitude_m / um,
            e.vibration_amplitude_m / um, printf_number("%g Hz", f));
    }
    if (e.drift_m_per_s != 0)
      add("thermal_drift", results::name_along(results::centre_drift, L), e.drift_m_per_s / um * 60,
          std::abs(e.drift_m_per_s) * duration_s / um,
          printf_number("%.3g um over the test", std::abs(e.drift_m_per_s) * duration_s / um));
    if (e.scale_drift_per_s != 0)
      cannot("scale drift " + L + " " + printf_number("%g ppm/h", e.scale_drift_per_s * 3.6e9),
             "a scale growing with time is not in the effect library (EXPLAIN would leave it unexplained)");
    if (e.bump_amplitude_m != 0)
      cannot("guideway bump on " + L + " " + printf_number("%g um", e.bump_amplitude_m / um) + printf_number(" at %g mm", e.bump_center_m * 1e3),
             "outside the effect library: EXPLAIN locates it (unexplained) where the carriage passes it");
  }
  {
    // Position loops: the difference of the two in-plane lags, and the lag itself.
    const double la = m.axis[static_cast<std::size_t>(a)].servo_lag_s, lb = m.axis[static_cast<std::size_t>(b)].servo_lag_s;
    double v_max = 0;
    for (const auto& r : runs) v_max = std::max(v_max, r.feed_m_per_s);
    if (la != lb) {
      if (ccw && cw)
        add("servo_mismatch", results::name(results::servo_mismatch), (la - lb) * 1e3,
            0.5 * v_max * std::abs(la - lb) / um, "");
      else
        cannot("servo mismatch " + printf_number("%g ms", (la - lb) * 1e3), "one direction only: in each direction it is squareness");
    }
    const double lag = 0.5 * (la + lb);
    if (lag > 0) {
      if (angles_from_encoders)
        cannot("servo lag " + printf_number("%g ms", lag * 1e3),
               "the session's angles are read from the axis encoders, which follow the drives: angle and bar agree "
               "(it only shrinks the circle by r (omega tau)^2 / 2, part of Lai's scale)");
      else
        add("servo_lag", results::name(results::servo_lag), lag * 1e3, 0.0, "the base's shape seen omega x lag early");
    }
  }
  {
    const auto& e = m.axis[static_cast<std::size_t>(normal)];
    const std::string N = letter(normal);
    const std::string off = "the " + N + " axis does not move in a " + plane + " test";
    if (e.drift_m_per_s != 0) {
      const double along = std::abs(e.drift_m_per_s) * duration_s / um;
      cannot(N + " drift " + printf_number("%g um/h", e.drift_m_per_s / um * 3600),
             off + "; over the " + printf_number("%.0f s", duration_s) + " of data it moves the socket " + printf_number("%.2g um", along) +
                 " along the plane's normal, which the bar reads times h/L (" + printf_number("%.2g", max_lean) + "): " +
                 printf_number("%.2g um", along * max_lean));
    }
    if (e.vibration_amplitude_m != 0)
      cannot(N + " vibration " + printf_number("%g um", e.vibration_amplitude_m / um),
             off + "; it reaches the bar only through h/L (" + printf_number("%.2g", max_lean) + ")");
    if (e.backlash_m != 0 || e.cyclic_amplitude_m != 0 || e.lateral_play_m != 0 || e.reversal_spike_m != 0)
      cannot(N + " backlash, cyclic error, play or spikes", off);
  }
  // The bar.
  if (m.dbb.bar_drift_m_per_s != 0)
    add("thermal_drift", results::name(results::bar_drift), m.dbb.bar_drift_m_per_s / um * 60,
        std::abs(m.dbb.bar_drift_m_per_s) * duration_s / um, "");
  if (m.dbb.nonlinearity_quadratic_per_m != 0) {
    const double q = m.dbb.nonlinearity_quadratic_per_m * um;
    if (radii.size() < 2)
      cannot("bar non-linearity " + printf_number("%g /um", q), "one radius: its harmonics of the centre offset are Lai's base's shapes");
    else
      add("sensor_nonlinearity", results::name(results::sensor_quadratic), q, 0.0, "");
  }
  if (m.dbb.slip_m != 0)
    cannot("ball slip " + printf_number("%g um", m.dbb.slip_m / um) + printf_number(" at %g s", m.dbb.slip_time_s),
           "an instrument failure outside the effect library: EXPLAIN locates it (unexplained)");
  // The spindle.
  const auto& s = m.spindle;
  if (s.tilt_x_rad != 0 || s.tilt_y_rad != 0 || s.axial_runout_m != 0 || s.plate_parallelism_rad != 0) {
    std::string what = "spindle";
    if (s.tilt_x_rad != 0 || s.tilt_y_rad != 0) what += printf_number(" tilt %g", s.tilt_x_rad / um) + printf_number("/%g urad", s.tilt_y_rad / um);
    if (s.axial_runout_m != 0) what += printf_number(", axial run-out %g um", s.axial_runout_m / um);
    if (s.plate_parallelism_rad != 0) what += printf_number(", thrust plate %g urad", s.plate_parallelism_rad / um);
    cannot(what, "a DBB test does not turn the spindle (the run-out and profile sessions see these)");
  }
  t.diagnostics = diagnostics_truth(m, plane, a, b, runs);
  t.centre_offset_sign =
      "a centre offset is the circle's centre less the fixed ball's position, as the machine file's "
      "center_offset; Lai's fixed ball offset (e_x_um, e_y_um) is the fixed ball's less the centre: the "
      "opposite sign (docs/conventions.md)";
  t.note = "geometric errors (centre offset, scale, squareness, straightness, roll) are Lai's base: PARAMS lai3; "
           "the bar's noise is " + printf_number("%g um", noise_um) + " (EXPLAIN's noise_um)";
  return t;
}

MachineTruth runout_truth(const machine::MachineConfig& m, const std::vector<TruthRecord>& records) {
  if (records.empty()) throw std::invalid_argument("runout_truth: no records");
  MachineTruth t;
  double samples = 0, revolutions = 1e300, per_rev = 1e300, duration_s = 0;
  for (const auto& r : records) {
    samples += r.samples_per_rev * r.revolutions;
    revolutions = std::min(revolutions, r.revolutions);
    per_rev = std::min(per_rev, r.samples_per_rev);
    duration_s = std::max(duration_s, r.revolutions * 60.0 / r.rpm);
  }
  // As runout_explain searches: orders up to a quarter of the samples per revolution (2..50), resolved
  // to 1 / revolutions of an order.
  const double highest = std::clamp(std::floor(per_rev / 4.0), 2.0, 50.0);
  const double noise_um = m.noise.micrometer_m / um;
  const double floor_um = samples > 0 ? 7 * noise_um / std::sqrt(samples) : 0.0;
  const auto add = [&](std::string effect, const results::Parameter& p, double value, double signal_um,
                       std::string note, double order) {
    if (signal_um > 0 && signal_um < floor_um)
      note += (note.empty() ? "" : "; ") + printf_number("%.3g", signal_um) + " um in the reading, below the " +
              printf_number("%.2g", floor_um) + " um these samples resolve";
    t.findable.push_back({std::move(effect), results::name(p), value, std::move(note), order});
  };
  const auto cannot = [&](std::string what, std::string why) {
    t.unobservable.push_back({std::move(what), std::move(why)});
  };
  const auto& s = m.spindle;
  // The synchronous harmonics: the axial run-out (order 2), the [spindle] harmonics (read with their sign
  // reversed) and the plate's form, summed by order: one record cannot tell them apart. The amplitude the
  // probe sees; the phase counts from the record's first reading, so it is not compared.
  std::map<int, std::complex<double>> harmonics;
  if (s.axial_runout_m != 0) harmonics[2] -= s.axial_runout_m;
  for (const auto& l : s.synchronous)
    harmonics[static_cast<int>(std::lround(l.order))] -= std::polar(l.amplitude_m, l.phase_rad);
  for (const auto& l : s.plate_form)
    harmonics[static_cast<int>(std::lround(l.order))] += std::polar(l.amplitude_m, l.phase_rad);
  for (const auto& [order, phasor] : harmonics) {
    const double a_um = std::abs(phasor) / um;
    if (order > highest)
      cannot(
          printf_number("synchronous harmonic of order %g", order) + printf_number(", %g um", a_um),
          printf_number("above the %g per revolution the samples resolve (a quarter of them per revolution)", highest));
    else
      add("synchronous_harmonic", results::synchronous_harmonic, a_um, a_um, printf_number("order %g", order), order);
  }
  for (const auto& l : s.asynchronous) {
    const double a_um = l.amplitude_m / um;
    const double off = std::abs(l.order - std::round(l.order));
    if (l.order > highest + 0.5)
      cannot(printf_number("asynchronous line at %g per revolution", l.order) + printf_number(", %g um", a_um),
             printf_number("above the %g per revolution the samples resolve", highest));
    else if (off < 1.0 / revolutions)
      cannot(printf_number("asynchronous line at %g per revolution", l.order) + printf_number(", %g um", a_um),
             printf_number("within 1/%g of an order of a harmonic: the record is too short to tell it from one",
                           revolutions));
    else
      add("asynchronous_line", results::asynchronous_line, a_um, a_um, printf_number("order %g", l.order), l.order);
  }
  // The reading is the plate's height under the probe: the spindle's growth along +z reads with its sign reversed.
  if (s.axial_growth_m_per_s != 0)
    add("thermal_drift", results::axial_growth, -s.axial_growth_m_per_s / um * 60.0,
        std::abs(s.axial_growth_m_per_s) * duration_s / um, "read as the plate's height: the growth's sign reversed",
        0.0);
  if (s.speed_ramp_per_s != 0) add("speed_variation", results::speed_ramp, s.speed_ramp_per_s * 6000.0, 0.0, "", 0.0);
  if (s.speed_ripple != 0) {
    const double nu = s.speed_ripple_per_rev;
    if (std::abs(nu - std::round(nu)) < 1.0 / revolutions)
      cannot(
          printf_number("speed ripple %g %%", s.speed_ripple * 100) + printf_number(" at %g per revolution", nu),
          "locked to the revolution, it repeats every revolution: it reads as synchronous harmonics of orders nu - 1 "
          "and nu + 1");
    else
      add("speed_ripple", results::speed_ripple, std::abs(s.speed_ripple) * 100.0, 0.0,
          printf_number("at %g per revolution", nu), nu);
  }
  if (s.tilt_y_rad != 0 || s.plate_parallelism_direction_rad != 0)
    cannot("the lean's direction",
           "the micrometer reads no spindle angle: a record's angle starts at its first reading");
  t.note =
      "the once-per-revolution term (the spindle's lean against the thrust plate: PARAMS runout_um) is the base; "
      "the micrometer's noise is " +
      printf_number("%g um", noise_um) + " (EXPLAIN's noise_um)";
  return t;
}

MachineTruth traverse_truth(const machine::MachineConfig& m) {
  MachineTruth t;
  const auto add = [&](std::string effect, const results::Parameter& p, double value, std::string note) {
    t.findable.push_back({std::move(effect), results::name(p), value, std::move(note), 0.0});
  };
  const double arcsec = std::numbers::pi / (180.0 * 3600.0);
  const auto& a = m.autocollimator;
  if (a.pitch_drift_rad_per_s != 0)
    add("angle_drift", results::angle_drift, a.pitch_drift_rad_per_s / arcsec * 60.0,
        "forward and return passes disagree by it times the time between their readings");
  if (a.rocking_rad != 0) add("reflector_rocking", results::reflector_rocking, a.rocking_rad / arcsec, "+ moving +x");
  const auto& x = m.axis[0];
  if (x.pitch_wave_rad != 0)
    add("pitch_wave", results::pitch_wave, x.pitch_wave_rad / arcsec,
        printf_number("period %g mm", x.pitch_wave_period_m * 1e3));
  if (a.head_roll_rad != 0)
    add("yaw_coupling", results::yaw_coupling, 100.0 * std::sin(a.head_roll_rad),
        "seen only where the yaw has a shape of its own");
  if (a.yaw_drift_rad_per_s != 0)
    t.unobservable.push_back({printf_number("yaw drift %g\"/min", a.yaw_drift_rad_per_s / arcsec * 60.0),
                              "EXPLAIN of a traverse explains the pitch readings"});
  t.note =
      "the traverse is of X (the emulator's axis); its pitch polynomial (PARAMS straightness) is the base; the "
      "autocollimator's noise is " +
      printf_number("%g\"", m.noise.autocollimator_rad / arcsec) + " a reading";
  return t;
}

}  // namespace guideway::simulators::scenarios
