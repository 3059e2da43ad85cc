// Loading a machine file (docs/machine.md) into a MachineConfig: units at the boundary (mm, um, urad,
// ppm, ms, deg, per hour) are converted to SI here.
#include <cmath>
#include <numbers>

#include "core/toml_access.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::simulators::machine {

namespace {

constexpr double um = 1e-6;
constexpr double deg = std::numbers::pi / 180.0;

// Polynomial given as coefficients of (position in mm)^k with the value in 1e-6 units (um or urad).
Polynomial micro_poly(const TableReader& t, std::string_view key) {
  Polynomial p;
  const auto c = t.get_doubles(key, {});
  double f = 1e-6;
  for (double ck : c) {
    if (!std::isfinite(ck)) t.fail(key, "coefficients must be finite numbers");
    p.c.push_back(ck * f);
    f *= 1e3;
  }
  return p;
}

// The spindle's error motion lines `<prefix>_orders`, `<prefix>_um`, `<prefix>_phase_deg` (arrays of
// equal length; phases optional): integer orders >= 2 when `integer` (the first order is the lean),
// otherwise non-integer orders (the plate's form, `plate_form_*`, is of whole orders too).
std::vector<SpindleErrors::Line> read_spindle_lines(const TableReader& t, const std::string& prefix, bool integer) {
  const std::string ok = prefix + "_orders", ak = prefix + "_um", pk = prefix + "_phase_deg";
  const auto orders = t.get_doubles(ok, {});
  const auto amps = t.get_doubles(ak, {});
  const auto phases = t.get_doubles(pk, std::vector<double>(orders.size(), 0.0));
  if (amps.size() != orders.size()) t.fail(ak, "needs one amplitude per order in " + ok);
  if (phases.size() != orders.size()) t.fail(pk, "needs one phase per order in " + ok);
  std::vector<SpindleErrors::Line> out;
  for (std::size_t i = 0; i < orders.size(); ++i) {
    const double o = orders[i];
    if (!std::isfinite(o) || !(o > 0) || o > 1000) t.fail(ok, "orders must be in (0, 1000]");
    if (integer && (o != std::round(o) || o < 2))
      t.fail(ok, "synchronous orders are whole numbers from 2 (once per revolution is the lean, tilt_x_urad)");
    if (!integer && o == std::round(o))
      t.fail(ok, "asynchronous orders are not whole numbers (a whole order repeats every revolution: harmonic_orders)");
    if (!std::isfinite(amps[i]) || std::abs(amps[i]) > 1e5) t.fail(ak, "amplitudes must be finite, |a| <= 1e5 um");
    if (!std::isfinite(phases[i])) t.fail(pk, "phases must be finite");
    out.push_back({o, amps[i] * um, phases[i] * deg});
  }
  return out;
}

AxisErrors read_axis(const TableReader& t) {
  AxisErrors e;
  e.scale = t.get_double("scale_ppm", 0.0, -1e5, 1e5) * 1e-6;
  static constexpr const char* tr[3] = {"e_x_um", "e_y_um", "e_z_um"};
  static constexpr const char* ro[3] = {"e_a_urad", "e_b_urad", "e_c_urad"};
  for (std::size_t i = 0; i < 3; ++i) {
    e.translation[i] = micro_poly(t, tr[i]);
    e.rotation[i] = micro_poly(t, ro[i]);
  }
  e.bending = t.get_bool("bending", false);
  e.servo_lag_s = t.get_double("servo_lag_ms", 0.0, 0.0, 1e4) * 1e-3;
  e.backlash_m = t.get_double("backlash_um", 0.0, 0.0, 1e5) * um;
  e.reversal_spike_m = t.get_double("reversal_spike_um", 0.0, -1e5, 1e5) * um;
  e.reversal_spike_decay_s = t.get_double("reversal_spike_decay_ms", 20.0, 1e-3, 1e5) * 1e-3;
  e.stick_slip_m = t.get_double("stick_slip_um", 0.0, -1e5, 1e5) * um;
  e.stick_slip_hz = t.get_double("stick_slip_hz", 10.0, 1e-3, 1e5);
  e.stick_slip_decay_s = t.get_double("stick_slip_decay_ms", 100.0, 1e-3, 1e5) * 1e-3;
  e.lateral_play_m = t.get_double("lateral_play_um", 0.0, -1e5, 1e5) * um;
  e.cyclic_amplitude_m = t.get_double("cyclic_amplitude_um", 0.0, -1e5, 1e5) * um;
  e.cyclic_period_m = t.get_double("cyclic_period_mm", 5.0, 1e-3, 1e4) * 1e-3;
  e.cyclic_phase_rad = t.get_double("cyclic_phase_deg", 0.0, -360.0, 360.0) * deg;
  e.pitch_wave_rad = t.get_double("pitch_wave_urad", 0.0, -1e5, 1e5) * um;
  e.pitch_wave_period_m = t.get_double("pitch_wave_period_mm", 100.0, 1e-3, 1e5) * 1e-3;
  e.pitch_wave_phase_rad = t.get_double("pitch_wave_phase_deg", 0.0, -360.0, 360.0) * deg;
  e.yaw_wave_rad = t.get_double("yaw_wave_urad", 0.0, -1e5, 1e5) * um;
  e.yaw_wave_period_m = t.get_double("yaw_wave_period_mm", 100.0, 1e-3, 1e5) * 1e-3;
  e.yaw_wave_phase_rad = t.get_double("yaw_wave_phase_deg", 0.0, -360.0, 360.0) * deg;
  e.scale_drift_per_s = t.get_double("scale_drift_ppm_per_h", 0.0, -1e5, 1e5) * 1e-6 / 3600.0;
  e.drift_m_per_s = t.get_double("drift_um_per_h", 0.0, -1e6, 1e6) * um / 3600.0;
  e.bump_amplitude_m = t.get_double("bump_um", 0.0, -1e5, 1e5) * um;
  e.bump_center_m = t.get_double("bump_center_mm", 0.0, -1e5, 1e5) * 1e-3;
  e.bump_width_m = t.get_double("bump_width_mm", 5.0, 1e-3, 1e5) * 1e-3;
  {
    const std::string d = t.get_choice("bump_direction", "y", {"x", "y", "z"});
    e.bump_direction = d == "x" ? 0 : (d == "y" ? 1 : 2);
  }
  e.vibration_amplitude_m = t.get_double("vibration_um", 0.0, 0.0, 1e5) * um;
  e.vibration_frequency_hz = t.get_double("vibration_hz", 0.0, 0.0, 1e6);
  e.encoder_resolution_m = t.get_double("encoder_resolution_um", 0.0, 0.0, 1e4) * um;
  e.encoder_noise_m = t.get_double("encoder_noise_um", 0.0, 0.0, 1e4) * um;
  t.reject_unknown_keys();
  return e;
}

MachineConfig read(const toml::table& root, const std::string& file) {
  TableReader top(root, file, "");
  MachineConfig m;
  if (auto t = top.table("machine")) {
    m.name = t->get_string("name", m.name);
    const auto off = t->get_doubles("tool_offset_mm", {0, 0, 0});
    if (off.size() != 3) t->fail("tool_offset_mm", "expected [x, y, z] in mm");
    for (std::size_t i = 0; i < 3; ++i) m.tool_offset[i] = off[i] * 1e-3;
    t->reject_unknown_keys();
  }
  if (auto t = top.table("noise")) {
    m.noise.seed = static_cast<std::uint64_t>(t->get_int("seed", 1, 0));
    m.noise.autocollimator_rad = t->get_double("autocollimator_arcsec", 0.0, 0.0, 1e4) * deg / 3600.0;
    m.noise.micrometer_m = t->get_double("micrometer_um", 0.0, 0.0, 1e4) * um;
    m.noise.profilometer_m = t->get_double("profilometer_um", 0.0, 0.0, 1e4) * um;
    m.noise.position_m = t->get_double("position_um", 0.0, 0.0, 1e4) * um;
    t->reject_unknown_keys();
  }
  if (auto t = top.table("squareness")) {
    m.squareness.xy = t->get_double("xy_urad", 0.0, -1e5, 1e5) * um;
    m.squareness.xz = t->get_double("xz_urad", 0.0, -1e5, 1e5) * um;
    m.squareness.yz = t->get_double("yz_urad", 0.0, -1e5, 1e5) * um;
    t->reject_unknown_keys();
  }
  if (auto t = top.table("dbb")) {
    m.dbb.center_offset = {t->get_double("center_offset_x_um", 0.0, -1e5, 1e5) * um,
                           t->get_double("center_offset_y_um", 0.0, -1e5, 1e5) * um,
                           t->get_double("center_offset_z_um", 0.0, -1e5, 1e5) * um};
    m.dbb.bar_length_error_m = t->get_double("bar_length_error_um", 0.0, -1e5, 1e5) * um;
    m.dbb.bar_drift_m_per_s = t->get_double("bar_drift_um_per_h", 0.0, -1e6, 1e6) * um / 3600.0;
    m.dbb.noise_m = t->get_double("noise_um", 0.0, 0.0, 1e4) * um;
    // dL in um in the file: q / um and c / um^2.
    m.dbb.nonlinearity_quadratic_per_m = t->get_double("nonlinearity_quadratic_per_um", 0.0, -1e3, 1e3) / um;
    m.dbb.nonlinearity_cubic_per_m2 = t->get_double("nonlinearity_cubic_per_um2", 0.0, -1e3, 1e3) / (um * um);
    m.dbb.slip_m = t->get_double("slip_um", 0.0, -1e5, 1e5) * um;
    m.dbb.slip_time_s = t->get_double("slip_time_s", 0.0, 0.0, 1e9);
    t->reject_unknown_keys();
  }
  if (auto t = top.table("spindle")) {
    m.spindle.tilt_x_rad = t->get_double("tilt_x_urad", 0.0, -1e5, 1e5) * um;
    m.spindle.tilt_y_rad = t->get_double("tilt_y_urad", 0.0, -1e5, 1e5) * um;
    m.spindle.axial_runout_m = t->get_double("axial_runout_um", 0.0, -1e5, 1e5) * um;
    m.spindle.plate_parallelism_rad = t->get_double("plate_parallelism_urad", 0.0, -1e5, 1e5) * um;
    m.spindle.plate_parallelism_direction_rad =
        t->get_double("plate_parallelism_direction_deg", 0.0, -360.0, 360.0) * deg;
    m.spindle.synchronous = read_spindle_lines(*t, "harmonic", true);
    m.spindle.asynchronous = read_spindle_lines(*t, "async", false);
    m.spindle.axial_growth_m_per_s = t->get_double("axial_growth_um_per_min", 0.0, -1e4, 1e4) * um / 60.0;
    m.spindle.speed_ramp_per_s = t->get_double("speed_ramp_percent_per_min", 0.0, -50.0, 50.0) * 0.01 / 60.0;
    m.spindle.plate_form = read_spindle_lines(*t, "plate_form", true);
    m.spindle.speed_ripple = t->get_double("speed_ripple_percent", 0.0, -50.0, 50.0) * 0.01;
    m.spindle.speed_ripple_per_rev = t->get_double("speed_ripple_per_rev", 0.0, 0.0, 1000.0);
    if (m.spindle.speed_ripple != 0 && m.spindle.speed_ripple_per_rev <= 0)
      t->fail("speed_ripple_per_rev", "a speed ripple needs its frequency in cycles per revolution (> 0)");
    t->reject_unknown_keys();
  }
  if (auto t = top.table("autocollimator")) {
    constexpr double arcsec = deg / 3600.0;
    m.autocollimator.pitch_drift_rad_per_s =
        t->get_double("pitch_drift_arcsec_per_min", 0.0, -1e4, 1e4) * arcsec / 60.0;
    m.autocollimator.yaw_drift_rad_per_s = t->get_double("yaw_drift_arcsec_per_min", 0.0, -1e4, 1e4) * arcsec / 60.0;
    m.autocollimator.rocking_rad = t->get_double("rocking_arcsec", 0.0, -1e4, 1e4) * arcsec;
    m.autocollimator.head_roll_rad = t->get_double("head_roll_deg", 0.0, -45.0, 45.0) * deg;
    t->reject_unknown_keys();
  }
  if (auto t = top.table("axis")) {
    static constexpr const char* names[3] = {"x", "y", "z"};
    for (std::size_t j = 0; j < 3; ++j) {
      if (auto a = t->table(names[j])) m.axis[j] = read_axis(*a);
    }
    t->reject_unknown_keys();
  }
  top.reject_unknown_keys();
  return m;
}

}  // namespace

MachineConfig parse_machine_config(std::string_view toml_text, const std::string& file_name) {
  const toml::table root = parse_toml(toml_text, file_name);
  return read(root, file_name);
}

MachineConfig load_machine_config(const std::string& path) {
  const toml::table root = parse_toml_file(path);
  return read(root, path);
}

namespace {

constexpr std::string_view machine_example_toml =
#include "machine_example.inc"
    ;

}  // namespace

MachineConfig default_machine_config() {
  return parse_machine_config(machine_example_toml, "<embedded config/machine-example.toml>");
}

}  // namespace guideway::simulators::machine
