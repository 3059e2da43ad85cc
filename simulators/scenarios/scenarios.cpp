// The EXPLAIN scenario suite (scenarios.hpp): recordings made in-process by the virtual machine with effects the model
// leaves out.
#include "simulators/scenarios/scenarios.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "core/number_format.hpp"
#include "models/explain/dbb_explain.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/explain.hpp"
#include "models/explain/profile_explain.hpp"
#include "results/parameters.hpp"
#include "simulators/machine/dbb_runs.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::simulators::scenarios {

using namespace models::flatness;  // the flatness models
using namespace models::explain;

namespace {

constexpr double pi = std::numbers::pi;
constexpr double um = 1e-6;
constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// The machine every DBB scenario starts from: the geometric errors Lai's base describes (so the base
// has work to do) and 0.4 um of bar noise; nothing the base leaves out.
machine::MachineConfig dbb_machine(std::uint64_t seed) {
  machine::MachineConfig m;
  m.name = "explain-scenario";
  m.dbb.center_offset = {2 * um, -3 * um, 0};
  m.dbb.noise_m = 0.4 * um;
  m.squareness.xy = 5e-6;
  m.axis[0].translation[1].c = {0, 0, 1e-4};  // X straightness along y: 1 um at 100 mm
  m.axis[0].scale = 3e-6;
  m.noise.seed = seed;
  return m;
}

struct DbbRunPlan {
  formats::DbbDirection direction = formats::DbbDirection::ccw;
  double feed_mm_per_min = 1000.0;
  double radius_mm = 100.0;
};

// A DBB scenario: what the machine has beyond dbb_machine(), the runs, and what must be found.
struct DbbScenario {
  std::string name;
  std::string concealment;
  std::function<void(machine::MachineConfig&)> inject;
  std::vector<Expectation> expected;
  std::vector<DbbRunPlan> runs{{formats::DbbDirection::ccw}, {formats::DbbDirection::cw}};
  double gap_s = 10.0;  // machine time between one run's end and the next one's start
  // Effects that live on a few samples (50 ms spikes, jerks), on a few hundredths of a um (the servo lag)
  // or on the difference between two radii (the bar's non-linearity) need the instrument's sample
  // density: quick mode keeps it for them.
  bool full_density = false;
  // The angles are the axis encoders' (a live session's, machine::AngleSource::encoders), not the commanded ones.
  bool encoder_angles = false;
  bool expect_unexplained = false;
  std::vector<double> where_deg;  // an out-of-library cause: the angles it must be located at
  // ... and the arcs the located places may span (empty: only those angles)
  std::vector<std::pair<double, double>> region_deg;
  // Beside real effects the base residual is structured at their places too: the cause outside the library
  // is then looked for among the places set aside (the report's `remaining`), run by run.
  bool where_set_aside = false;
  std::string where_run;                                           // ... in this run ("" = any)
  double where_time_s = std::numeric_limits<double>::quiet_NaN();  // ... at this time from the run's start
  // A knock on the bar (not a machine error): run `run` rings from `after_s` after its first sample,
  // um sin(2 pi hz dt) exp(-dt / decay_s).
  struct Knock {
    int run = -1;
    double after_s = 0, um = 0, hz = 0, decay_s = 0;
  } knock;
  // The ball slips in its cup during run `run`, `after_s` from its first sample, and is seated again before the
  // next run: the reading steps by um for the rest of that run only (machine::DbbErrors' slip stays for good).
  struct Reseated {
    int run = -1;
    double after_s = 0, um = 0;
  } reseated;
  // A dropout: run `run` loses its samples for duration_s from where its angle reaches from_deg (the
  // recording's gap, not the machine's: the samples are simply not there).
  struct Dropout {
    int run = -1;
    double from_deg = 0, duration_s = 0;
  } dropout;
};

DbbScenario sc(std::string name, std::string concealment, std::function<void(machine::MachineConfig&)> inject,
               std::vector<Expectation> expected,
               std::vector<DbbRunPlan> runs = {{formats::DbbDirection::ccw}, {formats::DbbDirection::cw}},
               double gap_s = 10.0) {
  DbbScenario s;
  s.name = std::move(name);
  s.concealment = std::move(concealment);
  s.inject = std::move(inject);
  s.expected = std::move(expected);
  s.runs = std::move(runs);
  s.gap_s = gap_s;
  return s;
}

// Runs one after another on one machine clock (start_time_s metadata), gap_s apart.
std::vector<formats::DbbRun> dbb_runs(const machine::MachineConfig& cfg, const DbbScenario& sc,
                                      const ScenarioOptions& o) {
  const machine::Machine machine(cfg);
  std::vector<formats::DbbRun> runs;
  double t0 = 0;
  for (std::size_t k = 0; k < sc.runs.size(); ++k) {
    machine::DbbCircleSpec spec;
    spec.radius_m = sc.runs[k].radius_mm * 1e-3;
    spec.direction = sc.runs[k].direction;
    spec.feed_m_per_s = sc.runs[k].feed_mm_per_min / 60000.0;
    const double omega = spec.feed_m_per_s / spec.radius_m;
    const double per_deg = o.samples_per_deg > 0 ? o.samples_per_deg : o.quick && !sc.full_density ? 3.0 : 10.0;
    spec.sample_rate_hz = omega * 180 / pi * per_deg;
    spec.t0_s = t0;
    spec.seed = o.seed * 1000 + k + 1;
    formats::DbbRun run =
        machine::simulate_dbb_run(machine, spec, "scenario-run" + std::to_string(k + 1),
                                  sc.encoder_angles ? machine::AngleSource::encoders : machine::AngleSource::commanded);
    if (sc.knock.run == static_cast<int>(k))
      for (std::size_t i = 0; i < run.t_s.size(); ++i)
        if (const double dt = run.t_s[i] - sc.knock.after_s; dt >= 0)
          run.dL_m[i] += sc.knock.um * um * std::sin(2 * pi * sc.knock.hz * dt) * std::exp(-dt / sc.knock.decay_s);
    if (sc.reseated.run == static_cast<int>(k))
      for (std::size_t i = 0; i < run.t_s.size(); ++i)
        if (run.t_s[i] >= sc.reseated.after_s) run.dL_m[i] += sc.reseated.um * um;
    if (sc.dropout.run == static_cast<int>(k)) {
      const double from_rad = sc.dropout.from_deg * pi / 180;
      std::size_t i = 0;
      while (i + 1 < run.angle_rad.size() && (run.angle_rad[i] - from_rad) * run.dir() < 0) ++i;
      run = machine::with_dropout(run, run.t_s[i], sc.dropout.duration_s);
    }
    run.metadata["start_time_s"] =
        printf_number("%.17g", o.clock_origin_s + std::stod(run.metadata.at("start_time_s")));
    runs.push_back(std::move(run));
    t0 += (2 * pi + 2 * spec.overshoot_rad) / omega + sc.gap_s;
  }
  return runs;
}

// Machine time at which run 1 (ccw from 0 deg, 45 deg feed-in) passes `deg`.
double run1_time_at_deg(const DbbScenario& sc, double deg) {
  const double omega = sc.runs.front().feed_mm_per_min / 60000.0 / (sc.runs.front().radius_mm * 1e-3);
  return (45.0 + deg) * pi / 180 / omega;
}

// What must be found: `effect` with its parameter `p` (of the xy plane's axis `axis`: x or y) near `truth`.
constexpr int along_x = 0, along_y = 1;
Expectation expect(std::string effect, const results::Parameter& p, int axis, double truth, double tolerance) {
  return {std::move(effect), results::name(p, "xy", axis), truth, tolerance};
}
Expectation expect(std::string effect, const results::Parameter& p, double truth, double tolerance) {
  return expect(std::move(effect), p, -1, truth, tolerance);
}

// Sizes of the injected effects (each visible above the 0.4 um noise at these feeds; the concealment
// column says what hides it).
void backlash(machine::MachineConfig& m, int axis, double um_) {
  m.axis[static_cast<std::size_t>(axis)].backlash_m = um_ * um;
}
void vibration(machine::MachineConfig& m, int axis, double um_, double hz) {
  m.axis[static_cast<std::size_t>(axis)].vibration_amplitude_m = um_ * um;
  m.axis[static_cast<std::size_t>(axis)].vibration_frequency_hz = hz;
}
void cyclic(machine::MachineConfig& m, int axis, double um_, double period_mm) {
  m.axis[static_cast<std::size_t>(axis)].cyclic_amplitude_m = um_ * um;
  m.axis[static_cast<std::size_t>(axis)].cyclic_period_m = period_mm * 1e-3;
}
void spike(machine::MachineConfig& m, int axis, double um_, double decay_ms) {
  m.axis[static_cast<std::size_t>(axis)].reversal_spike_m = um_ * um;
  m.axis[static_cast<std::size_t>(axis)].reversal_spike_decay_s = decay_ms * 1e-3;
}
void stick_slip(machine::MachineConfig& m, int axis, double um_, double hz, double decay_ms) {
  auto& a = m.axis[static_cast<std::size_t>(axis)];
  a.stick_slip_m = um_ * um;
  a.stick_slip_hz = hz;
  a.stick_slip_decay_s = decay_ms * 1e-3;
}
// A controller's per-joint tables holding each axis' backlash (LinuxCNC's COMP_FILE: the forward column b/2 short,
// the reverse b/2 long), switched by the commanded direction.
void backlash_tables(machine::MachineConfig& m, double x_um, double y_um) {
  for (std::size_t j = 0; j < 2; ++j) {
    const double half = 0.5 * (j == 0 ? x_um : y_um) * um;
    m.controller.tables[j] = {{-1.0, 1.0}, {-1.0 - half, 1.0 - half}, {-1.0 + half, 1.0 + half}};
  }
}
void lateral(machine::MachineConfig& m, int axis, double um_) {
  m.axis[static_cast<std::size_t>(axis)].lateral_play_m = um_ * um;
}
void centre_drift(machine::MachineConfig& m, double x_um_per_min, double y_um_per_min) {
  m.axis[0].drift_m_per_s = x_um_per_min * um / 60.0;
  m.axis[1].drift_m_per_s = y_um_per_min * um / 60.0;
}
void lags(machine::MachineConfig& m, double x_ms, double y_ms) {
  m.axis[0].servo_lag_s = x_ms * 1e-3;
  m.axis[1].servo_lag_s = y_ms * 1e-3;
}

// Two radii in both directions: a transducer's non-linearity of a centred circle's reading has the
// shapes of Lai's base (harmonics of the centre offset); at two radii the base's terms scale with the
// radius and the non-linearity does not.
// The bar set up 15/-12 um off the circle's centre (a usual set-up error) reads over +-19 um, where
// 0.001 dL^2 + 2e-5 dL^3 (um) adds up to 0.5 um; the gain it changes by over the reading (+-4 %) scales
// every other effect's reading with it.
void nonlinear_bar(machine::MachineConfig& m) {
  m.dbb.center_offset = {15 * um, -12 * um, 0};
  m.dbb.nonlinearity_quadratic_per_m = 0.001 / um;
  m.dbb.nonlinearity_cubic_per_m2 = 2e-5 / (um * um);
}
const std::vector<DbbRunPlan> two_radii{{formats::DbbDirection::ccw, 1000, 100},
                                        {formats::DbbDirection::cw, 1000, 100},
                                        {formats::DbbDirection::ccw, 1000, 50},
                                        {formats::DbbDirection::cw, 1000, 50}};
std::vector<DbbRunPlan> both_at(double feed) {
  return {{formats::DbbDirection::ccw, feed, 100}, {formats::DbbDirection::cw, feed, 100}};
}

const std::vector<DbbScenario>& dbb_scenarios() {
  using machine::MachineConfig;
  static const std::vector<DbbScenario> all = [] {
    std::vector<DbbScenario> v;
    // One effect at a time.
    v.push_back(sc("dbb_thermal_bar", "bar growth over the test, partly absorbed by the centre offset and scale terms",
                   [](MachineConfig& m) { m.dbb.bar_drift_m_per_s = 1.5 * um / 60.0; },
                   {expect("thermal_drift", results::bar_drift, 1.5, 0.15)}));
    v.push_back(sc(
        "dbb_servo_mismatch", "in each direction exactly the signature of squareness (the base has squareness)",
        [](MachineConfig& m) { lags(m, 0.06, 0.0); }, {expect("servo_mismatch", results::servo_mismatch, 0.06, 0.01)}));
    v.push_back(sc("dbb_backlash", "0.5 um steps under 0.4 um noise", [](MachineConfig& m) { backlash(m, 0, 0.5); },
                   {expect("backlash", results::backlash, along_x, 0.5, 0.1)}));
    v.push_back(sc("dbb_cyclic", "0.15 um lead-screw error (5 mm lead), below the 0.4 um noise in the raw residual",
                   [](MachineConfig& m) { cyclic(m, 0, 0.15, 5); },
                   {expect("cyclic_error", results::cyclic_error, along_x, 0.15, 0.04)}));
    v.push_back(
        sc("dbb_vibration",
           "0.3 um X-axis vibration at 7.3 Hz under 0.4 um noise, read through cos(angle): in the bar's own spectrum "
           "two lines at 7.3 Hz +- the circling frequency",
           [](MachineConfig& m) { vibration(m, 0, 0.3, 7.3); },
           {expect("vibration", results::vibration, along_x, 0.3, 0.05)}));
    v.push_back(sc(
        "dbb_servo_lag",
        "both drives 50 ms late at 2000 mm/min, the angles being the commanded ones: the base's shape seen "
        "0.95 deg early, opposite in the two directions (a few hundredths of a um)",
        [](MachineConfig& m) { lags(m, 50, 50); }, {expect("servo_lag", results::servo_lag, 50, 15)}, both_at(2000)));
    v.push_back(sc("dbb_reversal_spike", "1.5 um stiction spikes decaying in 50 ms, a few samples per reversal",
                   [](MachineConfig& m) { spike(m, 0, 1.5, 50); },
                   {expect("reversal_spike", results::reversal_spike, along_x, 1.5, 0.45)}));
    {
      // As a live session reads them (encoder angles): a drive's lag is then part of the angles, not an effect.
      DbbScenario s = sc("dbb_compensation_step",
                         "backlash of 1 um (X) and 2 um (Y) held by the controller's tables, which switch at the "
                         "commanded reversal while the drives follow 30 ms late (encoder angles, as a live "
                         "session's; the bar's 0.1 um noise): a dip of about half the backlash at each reversal, "
                         "some 3 samples long, a reversal spike's place and size",
                         [](MachineConfig& m) {
                           m.dbb.noise_m = 0.1 * um;
                           backlash(m, 0, 1.0);
                           backlash(m, 1, 2.0);
                           lags(m, 30, 30);
                           backlash_tables(m, 1.0, 2.0);
                         },
                         {expect("compensation_step", results::compensation_step, along_x, 1.0, 0.2),
                          expect("compensation_step", results::compensation_step, along_y, 2.0, 0.2)});
      s.encoder_angles = true;
      v.push_back(std::move(s));
    }
    v.push_back(sc("dbb_lateral_play",
                   "Y carriage shifts 1 um sideways with its direction: a step along x where Y reverses",
                   [](MachineConfig& m) { lateral(m, 1, 1.0); },
                   {expect("lateral_play", results::lateral_play, along_y, 1.0, 0.1)}));
    v.push_back(sc("dbb_stick_slip", "2 um jerks at 10 Hz decaying in 200 ms after each X reversal",
                   [](MachineConfig& m) { stick_slip(m, 0, 2.0, 10, 200); },
                   {expect("stick_slip", results::stick_slip, along_x, 2.0, 0.4)}));
    v.push_back(
        sc("dbb_sensor_nonlinearity",
           "the bar reads dL + 0.001 dL^2 + 2e-5 dL^3 (um), set up 19 um off centre: on one circle the harmonics "
           "of Lai's base; separable at two radii",
           nonlinear_bar, {expect("sensor_nonlinearity", results::sensor_quadratic, 0.001, 0.0003)}, two_radii));
    v.push_back(sc(
        "dbb_centre_drift",
        "the circle's centre drifts in the plane, X +1.0 and Y -0.67 um/min, the second run 90 s later at 600 "
        "mm/min: along one axis each drift is half explained",
        [](MachineConfig& m) { centre_drift(m, 1.0, -0.67); },
        {expect("thermal_drift", results::centre_drift, along_x, 1.0, 0.1),
         expect("thermal_drift", results::centre_drift, along_y, -0.67, 0.1)},
        both_at(600), 90.0));
    // Pairs: every effect of the DBB library in at least two, on either axis.
    v.push_back(sc("dbb_pair_backlash_vibration", "X backlash 0.8 um and a 0.4 um Y vibration at 9.1 Hz",
                   [](MachineConfig& m) {
                     backlash(m, 0, 0.8);
                     vibration(m, 1, 0.4, 9.1);
                   },
                   {expect("backlash", results::backlash, along_x, 0.8, 0.1),
                    expect("vibration", results::vibration, along_y, 0.4, 0.05)}));
    v.push_back(sc("dbb_pair_backlash_cyclic", "Y backlash 0.8 um and a 0.3 um X cyclic error of 5 mm lead",
                   [](MachineConfig& m) {
                     backlash(m, 1, 0.8);
                     cyclic(m, 0, 0.3, 5);
                   },
                   {expect("backlash", results::backlash, along_y, 0.8, 0.1),
                    expect("cyclic_error", results::cyclic_error, along_x, 0.3, 0.05)}));
    v.push_back(sc("dbb_pair_mismatch_spike", "0.06 ms servo mismatch and 1.5 um X reversal spikes (50 ms)",
                   [](MachineConfig& m) {
                     lags(m, 0.06, 0);
                     spike(m, 0, 1.5, 50);
                   },
                   {expect("servo_mismatch", results::servo_mismatch, 0.06, 0.01),
                    expect("reversal_spike", results::reversal_spike, along_x, 1.5, 0.45)}));
    v.push_back(sc("dbb_pair_mismatch_drift", "0.06 ms servo mismatch and the centre drifting X +1.0, Y -0.6 um/min",
                   [](MachineConfig& m) {
                     lags(m, 0.06, 0);
                     centre_drift(m, 1.0, -0.6);
                   },
                   {expect("servo_mismatch", results::servo_mismatch, 0.06, 0.01),
                    expect("thermal_drift", results::centre_drift, along_x, 1.0, 0.15),
                    expect("thermal_drift", results::centre_drift, along_y, -0.6, 0.15)}));
    v.push_back(sc(
        "dbb_pair_lag_cyclic",
        "drives 50 ms late (2000 mm/min) and a 0.3 um Y cyclic error of 8 mm lead, at the drives' positions",
        [](MachineConfig& m) {
          lags(m, 50, 50);
          cyclic(m, 1, 0.3, 8);
        },
        {expect("servo_lag", results::servo_lag, 50, 15),
         expect("cyclic_error", results::cyclic_error, along_y, 0.3, 0.05)},
        both_at(2000)));
    v.push_back(sc(
        "dbb_pair_lag_lateral", "drives 50 ms late (2000 mm/min) and 1 um lateral play of Y",
        [](MachineConfig& m) {
          lags(m, 50, 50);
          lateral(m, 1, 1.0);
        },
        {expect("servo_lag", results::servo_lag, 50, 15),
         expect("lateral_play", results::lateral_play, along_y, 1.0, 0.15)},
        both_at(2000)));
    v.push_back(sc("dbb_pair_lateral_bar_drift", "1 um lateral play of X and the bar growing 1.5 um/min",
                   [](MachineConfig& m) {
                     lateral(m, 0, 1.0);
                     m.dbb.bar_drift_m_per_s = 1.5 * um / 60.0;
                   },
                   {expect("lateral_play", results::lateral_play, along_x, 1.0, 0.1),
                    expect("thermal_drift", results::bar_drift, 1.5, 0.15)}));
    v.push_back(sc("dbb_pair_spike_stick_slip",
                   "1.5 um Y reversal spikes (50 ms) and 2 um X stick-slip (10 Hz, 200 ms): both at reversals",
                   [](MachineConfig& m) {
                     spike(m, 1, 1.5, 50);
                     stick_slip(m, 0, 2.0, 10, 200);
                   },
                   {expect("reversal_spike", results::reversal_spike, along_y, 1.5, 0.45),
                    expect("stick_slip", results::stick_slip, along_x, 2.0, 0.4)}));
    v.push_back(sc(
        "dbb_pair_stick_slip_nonlinearity", "2 um Y stick-slip (10 Hz, 200 ms) and the bar's non-linearity (two radii)",
        [](MachineConfig& m) {
          stick_slip(m, 1, 2.0, 10, 200);
          nonlinear_bar(m);
        },
        {expect("stick_slip", results::stick_slip, along_y, 2.0, 0.4),
         expect("sensor_nonlinearity", results::sensor_quadratic, 0.001, 0.0003)},
        two_radii));
    v.push_back(sc(
        "dbb_pair_nonlinearity_vibration", "the bar's non-linearity and a 0.4 um X vibration at 7.3 Hz (two radii)",
        [](MachineConfig& m) {
          nonlinear_bar(m);
          vibration(m, 0, 0.4, 7.3);
        },
        {expect("sensor_nonlinearity", results::sensor_quadratic, 0.001, 0.0003),
         expect("vibration", results::vibration, along_x, 0.4, 0.05)},
        two_radii));
    // Three at once.
    v.push_back(sc("dbb_three_backlash_mismatch_cyclic",
                   "X/Y backlash 1.2/0.6 um, 0.08 ms servo mismatch (Y lags), a 0.5 um Y cyclic error of 4 mm lead",
                   [](MachineConfig& m) {
                     backlash(m, 0, 1.2);
                     backlash(m, 1, 0.6);
                     lags(m, 0, 0.08);
                     cyclic(m, 1, 0.5, 4);
                   },
                   {expect("backlash", results::backlash, along_x, 1.2, 0.1),
                    expect("backlash", results::backlash, along_y, 0.6, 0.1),
                    expect("servo_mismatch", results::servo_mismatch, -0.08, 0.01),
                    expect("cyclic_error", results::cyclic_error, along_y, 0.5, 0.05)}));
    v.push_back(sc("dbb_three_backlash_vibration_drift",
                   "X backlash 0.8 um, a 0.4 um X vibration at 6.1 Hz and the centre drifting X +1.0, Y -0.6 um/min",
                   [](MachineConfig& m) {
                     backlash(m, 0, 0.8);
                     vibration(m, 0, 0.4, 6.1);
                     centre_drift(m, 1.0, -0.6);
                   },
                   {expect("backlash", results::backlash, along_x, 0.8, 0.1),
                    expect("vibration", results::vibration, along_x, 0.4, 0.05),
                    expect("thermal_drift", results::centre_drift, along_x, 1.0, 0.15),
                    expect("thermal_drift", results::centre_drift, along_y, -0.6, 0.15)}));
    v.push_back(sc("dbb_three_lateral_cyclic_vibration",
                   "1 um lateral play of Y, a 0.3 um X cyclic error of 5 mm lead and a 0.4 um Y vibration at 9.1 Hz",
                   [](MachineConfig& m) {
                     lateral(m, 1, 1.0);
                     cyclic(m, 0, 0.3, 5);
                     vibration(m, 1, 0.4, 9.1);
                   },
                   {expect("lateral_play", results::lateral_play, along_y, 1.0, 0.1),
                    expect("cyclic_error", results::cyclic_error, along_x, 0.3, 0.05),
                    expect("vibration", results::vibration, along_y, 0.4, 0.05)}));
    // Nothing left out.
    v.push_back(sc("dbb_null", "nothing left out: geometric errors of the base and 0.4 um noise only",
                   [](MachineConfig&) {}, {}));
    v.push_back(sc("dbb_null_feeds", "nothing left out; four runs, both directions at 500 and 2000 mm/min",
                   [](MachineConfig&) {}, {},
                   {{formats::DbbDirection::ccw, 500, 100},
                    {formats::DbbDirection::cw, 500, 100},
                    {formats::DbbDirection::ccw, 2000, 100},
                    {formats::DbbDirection::cw, 2000, 100}}));
    v.push_back(sc("dbb_null_three_runs", "nothing left out; three runs (ccw, cw, ccw): whole runs held out",
                   [](MachineConfig&) {}, {},
                   {{formats::DbbDirection::ccw}, {formats::DbbDirection::cw}, {formats::DbbDirection::ccw}}));
    v.push_back(sc("dbb_null_noisy", "nothing left out; 1.5 um of bar noise",
                   [](MachineConfig& m) { m.dbb.noise_m = 1.5 * um; }, {}));
    // Causes outside the library.
    {
      DbbScenario bump =
          sc("dbb_bump", "1.5 um local bump (5 mm wide) on the X guideway at x = 60 mm, outside the library",
             [](MachineConfig& m) {
               m.axis[0].bump_amplitude_m = 1.5 * um;
               m.axis[0].bump_center_m = 0.06;
               m.axis[0].bump_width_m = 0.005;
               m.axis[0].bump_direction = 1;
             },
             {});
      bump.expect_unexplained = true;
      // x = 60 mm on a 100 mm circle about the origin: zeta = +-acos(0.6).
      bump.where_deg = {std::acos(0.6) * 180 / pi, 360 - std::acos(0.6) * 180 / pi};
      v.push_back(bump);
    }
    {
      DbbScenario slip = sc("dbb_ball_slip",
                            "an instrument failure: the ball slips 1 um in its socket at 100 deg of the first run and "
                            "stays there, a step of the reading outside the library",
                            {}, {});
      slip.expect_unexplained = true;
      slip.where_deg = {100};
      // A step's mismatch is the stretch before it (the base fits the run's mean): from the run's start
      // (0 deg, 360 across the wrap) to the slip.
      slip.region_deg = {{0, 100}};
      const double t = run1_time_at_deg(slip, 100);
      slip.inject = [t](MachineConfig& m) {
        m.dbb.slip_m = 1.0 * um;
        m.dbb.slip_time_s = t;
      };
      v.push_back(slip);
    }
    // A cause outside the library beside real effects: found in the rest, the cause set aside and located.
    const auto slip_beside = [](std::string name, std::string concealment, std::function<void(MachineConfig&)> effects,
                                std::vector<Expectation> expected) {
      DbbScenario f = sc(std::move(name), std::move(concealment), {}, std::move(expected));
      f.expect_unexplained = true;
      f.where_deg = {100};
      // The stretch before the slip, and the run's ends (its start and end levels differ by the step).
      f.region_deg = {{-10, 100}};
      f.where_set_aside = true;
      f.where_run = "run1 (ccw)";
      const double t = run1_time_at_deg(f, 100);
      f.inject = [t, effects = std::move(effects)](MachineConfig& m) {
        effects(m);
        m.dbb.slip_m = 1.0 * um;
        m.dbb.slip_time_s = t;
      };
      return f;
    };
    v.push_back(slip_beside("dbb_slip_beside_backlash",
                            "the ball slips 1 um at 100 deg of the first run beside 0.8 um X backlash: the step's "
                            "structure is most of the residual, so the backlash alone removes too little of it",
                            [](MachineConfig& m) { backlash(m, 0, 0.8); },
                            {expect("backlash", results::backlash, along_x, 0.8, 0.1)}));
    // 0.8 um X backlash and a 0.4 um Y vibration at 9.1 Hz beside a slip that stays and one seated again.
    const auto backlash_vibration = [](MachineConfig& m) {
      backlash(m, 0, 0.8);
      vibration(m, 1, 0.4, 9.1);
    };
    const std::vector<Expectation> backlash_vibration_found{expect("backlash", results::backlash, along_x, 0.8, 0.1),
                                                           expect("vibration", results::vibration, along_y, 0.4, 0.05)};
    v.push_back(slip_beside("dbb_slip_beside_two",
                            "the ball slips 1 um at 100 deg of the first run beside 0.8 um X backlash and a 0.4 um Y "
                            "vibration at 9.1 Hz",
                            backlash_vibration, backlash_vibration_found));
    // Issue 41 item 10: a ball that slips once in its cup mid-run, 14.4 s into the first run (137.5 deg), and is
    // seated again before the second (the step stays for the rest of its run only); alone, beside one effect and two.
    // The place is set aside and the effects found in the rest, with the reading free to stand off after the place
    // and, apart, in the runs after it: the step alone left the second run's level to a ccw/cw effect (lateral play
    // X -0.93 / Y +0.94 um on a machine with none). Beside a backlash and a vibration the base alone leaves the
    // backlash's reversal at 180 deg as a step above the slip's, 42.5 deg before it: the step is sought beside the
    // findings (engine/level_step.hpp winning_step).
    const auto reseated = [](std::string name, std::string concealment, std::function<void(MachineConfig&)> effects,
                             std::vector<Expectation> expected) {
      DbbScenario f = sc(std::move(name), std::move(concealment), std::move(effects), std::move(expected));
      constexpr double after_s = 14.4;
      const double omega = f.runs.front().feed_mm_per_min / 60000.0 / (f.runs.front().radius_mm * 1e-3);
      f.expect_unexplained = true;
      f.where_deg = {after_s * omega * 180 / pi};
      f.where_set_aside = true;
      f.where_run = "run1 (ccw)";
      f.where_time_s = after_s;
      f.reseated = {0, after_s, 1.0};
      return f;
    };
    v.push_back(reseated("dbb_slip_reseated",
                         "the ball slips 1 um 14.4 s into the first run (137.5 deg) and is seated again before the "
                         "second: a step for the rest of its run only, outside the library",
                         [](MachineConfig&) {}, {}));
    // A lateral play is mostly a ccw/cw level (its X and Y apart by their 4th harmonic once the runs' levels are
    // free): beside the slip its u is some 4.6 times that of dbb_lateral_play, hence 2 um and 0.45 um.
    v.push_back(reseated("dbb_slip_reseated_beside_lateral",
                         "the same slip, seated again before the second run, beside 2 um lateral play of Y: the play "
                         "is a ccw/cw level as well as a shape, the slip one run's level",
                         [](MachineConfig& m) { lateral(m, 1, 2.0); },
                         {expect("lateral_play", results::lateral_play, along_y, 2.0, 0.45)}));
    v.push_back(reseated("dbb_slip_reseated_beside_two",
                         "the same slip, seated again before the second run, beside 0.8 um X backlash and 2 um "
                         "lateral play of Y",
                         [](MachineConfig& m) {
                           backlash(m, 0, 0.8);
                           lateral(m, 1, 2.0);
                         },
                         {expect("backlash", results::backlash, along_x, 0.8, 0.1),
                          expect("lateral_play", results::lateral_play, along_y, 2.0, 0.45)}));
    v.push_back(reseated("dbb_slip_reseated_beside_backlash_vibration",
                         "the same slip, seated again before the second run, beside 0.8 um X backlash and a 0.4 um Y "
                         "vibration at 9.1 Hz",
                         backlash_vibration, backlash_vibration_found));
    {
      // A knock during the second run (cw from 0 deg; times from its first sample, as the run file counts
      // them): 4 um ringing at 20 Hz, decaying in 150 ms, 15 s into the run (at 216.8 deg).
      DbbScenario knock = sc("dbb_knock_once",
                             "a knock 15 s into the second run: the bar rings 4 um at 20 Hz decaying in 150 ms, once, "
                             "beside 0.8 um X backlash in both runs",
                             {}, {expect("backlash", results::backlash, along_x, 0.8, 0.1)});
      knock.expect_unexplained = true;
      knock.full_density = true;  // 20 Hz ringing: 3 samples per degree would alias it
      const double omega = knock.runs.front().feed_mm_per_min / 60000.0 / (knock.runs.front().radius_mm * 1e-3);
      const double after_s = 15.0;
      knock.where_deg = {360.0 - after_s * omega * 180 / pi};
      knock.where_set_aside = true;
      knock.where_run = "run2 (cw)";
      knock.where_time_s = after_s;
      knock.inject = [](MachineConfig& m) { backlash(m, 0, 0.8); };
      knock.knock = {1, after_s, 4.0, 20.0, 0.15};
      v.push_back(knock);
    }
    {
      // A recording's dropout, not a machine error: 1.1 s (10.5 deg at 1000 mm/min) of the first run lost
      // across X's reversal at 180 deg. The rest still holds X's other reversals and both of Y's.
      DbbScenario gap = sc("dbb_dropout_beside_backlash",
                           "1.1 s of the first run lost from 175 deg (across X's reversal) beside 0.8 um X and 0.5 um "
                           "Y backlash: the gap costs the data in it, not the run",
                           [](MachineConfig& m) {
                             backlash(m, 0, 0.8);
                             backlash(m, 1, 0.5);
                           },
                           {expect("backlash", results::backlash, along_x, 0.8, 0.1),
                            expect("backlash", results::backlash, along_y, 0.5, 0.1)});
      gap.dropout = {0, 175.0, 1.1};
      v.push_back(gap);
    }
    for (auto& s : v)
      for (const auto& e : s.expected)
        if (const auto* effect = models::explain::effects::find(e.effect); effect && effect->needs_dense_sampling)
          s.full_density = true;
    return v;
  }();
  return all;
}

const DbbScenario* find_dbb(const std::string& name) {
  for (const auto& s : dbb_scenarios())
    if (s.name == name) return &s;
  return nullptr;
}

// Every expectation against the findings, and the common checks.
void evaluate(ScenarioResult& s) {
  const Report& r = s.report;
  std::string why;
  s.checks.clear();
  s.extra.clear();
  for (const auto& e : s.expected) {
    Check c{e, false, nan, nan, false};
    for (const auto& f : r.findings)
      if (f.effect == e.effect)
        for (const auto& p : f.parameters)
          if (p.name == e.parameter) {
            c.found = true;
            c.value = p.value;
            c.u = p.u;
          }
    c.within = c.found && std::abs(c.value - e.truth) <= e.tolerance;
    if (!c.found)
      why += e.effect + " (" + e.parameter + ") not found; ";
    else if (!c.within)
      why += e.parameter + " = " + printf_number("%.4g", c.value) + ", truth " + printf_number("%.4g", e.truth) +
             " +/- " + printf_number("%.3g", e.tolerance) + "; ";
    s.checks.push_back(c);
  }
  for (const auto& f : r.findings) {
    const bool expected = std::any_of(s.expected.begin(), s.expected.end(), [&](const Expectation& e) {
      if (e.effect != f.effect) return false;
      return std::any_of(f.parameters.begin(), f.parameters.end(),
                         [&](const ParamValue& p) { return p.name == e.parameter; });
    });
    if (!expected) {
      s.extra.push_back(f.effect);
      why += "unexpected finding " + f.effect + "; ";
    }
  }
  if (!s.expected.empty() && !(r.final_fit.heldout_rms_um < r.baseline.heldout_rms_um))
    why += "held-out RMS not improved; ";
  if (r.unexplained != s.expect_unexplained)
    why += std::string("unexplained is ") + (r.unexplained ? "true" : "false") + "; ";
  s.pass = why.empty();
  s.failure = why;
}

// Located at each expected angle (within 3 deg of a range) and nowhere else: every range reaches an
// expected angle or lies within an expected arc (3 deg of slack, 360 deg being 0); in the expected run at the
// expected time from its start (within 0.5 s), when the scenario names them.
void check_located(const DbbScenario& sc, ScenarioResult& s) {
  const auto inside = [&](double lo, double hi) {
    for (double d : sc.where_deg)
      if (lo - 3 <= d && d <= hi + 3) return true;
    for (const auto& [a, b] : sc.region_deg)
      for (double shift : {-360.0, 0.0, 360.0})
        if (lo + shift >= a - 3 && hi + shift <= b + 3) return true;
    return false;
  };
  std::vector<std::pair<double, double>> ranges;
  std::string located;
  bool in_run = sc.where_run.empty() && !std::isfinite(sc.where_time_s);
  if (sc.where_set_aside) {
    for (const auto& mm : s.report.remaining)
      for (const auto& l : mm.locations) {
        if (!l.set_aside) continue;
        ranges.emplace_back(std::min(l.where.first, l.where.second), std::max(l.where.first, l.where.second));
        located += (located.empty() ? "" : ", ") + l.run + " " + printf_number("%.4g", ranges.back().first) + ".." +
                   printf_number("%.4g", ranges.back().second) + " deg, " +
                   printf_number("%.1f", l.t_from_run_start_s.first) + ".." +
                   printf_number("%.1f", l.t_from_run_start_s.second) + " s" + (l.repeats_in.empty() ? " (once)" : "");
        const bool run_ok = sc.where_run.empty() || l.run == sc.where_run;
        const bool time_ok = !std::isfinite(sc.where_time_s) || (l.t_from_run_start_s.first - 0.5 <= sc.where_time_s &&
                                                                 sc.where_time_s <= l.t_from_run_start_s.second + 0.5);
        in_run = in_run || (run_ok && time_ok);
      }
  } else {
    for (const auto& mm : s.report.mismatch) {
      if (mm.domain != "angle_deg") continue;
      for (const auto& [lo, hi] : mm.ranges) {
        ranges.emplace_back(lo, hi);
        located += (located.empty() ? "" : ", ") + printf_number("%.4g", lo) + ".." + printf_number("%.4g", hi);
      }
    }
    if (!located.empty()) located += " deg";
  }
  s.located = located;
  std::vector<bool> hit(sc.where_deg.size(), false);
  bool elsewhere = false;
  for (const auto& [lo, hi] : ranges) {
    for (std::size_t k = 0; k < sc.where_deg.size(); ++k)
      hit[k] = hit[k] || (lo - 3 <= sc.where_deg[k] && sc.where_deg[k] <= hi + 3);
    // Among the places set aside beside real effects a partial fit's leftover may be too: there only the
    // expected place is required.
    elsewhere = elsewhere || (!sc.where_set_aside && !inside(lo, hi));
  }
  std::string where;
  for (double d : sc.where_deg) where += (where.empty() ? "" : ", ") + printf_number("%.1f", d);
  if (!sc.where_run.empty()) where += " in " + sc.where_run;
  if (std::isfinite(sc.where_time_s)) where += " at " + printf_number("%.1f", sc.where_time_s) + " s";
  s.expect_where = where;
  if (std::find(hit.begin(), hit.end(), false) != hit.end() || !in_run) {
    s.pass = false;
    s.failure += "not located at " + where + "; ";
  }
  if (elsewhere) {
    s.pass = false;
    s.failure += "mismatch located elsewhere as well; ";
  }
}

ScenarioResult dbb_scenario(const DbbScenario& sc, const ScenarioOptions& o) {
  ScenarioResult s;
  s.name = sc.name;
  s.model = "dbb";
  s.concealment = sc.concealment;
  s.expected = sc.expected;
  s.expect_unexplained = sc.expect_unexplained;
  machine::MachineConfig m = dbb_machine(o.seed);
  sc.inject(m);
  s.report = models::explain::explain(dbb_problem(dbb_runs(m, sc, o)), o.explain);
  evaluate(s);
  if (!sc.where_deg.empty()) check_located(sc, s);
  return s;
}

// A faced part (Mu's set-up, scaled: a 20 mm radius at 107 rpm, a sharp tool so that no feed marks
// form): the spindle leans 5 urad towards +x (squareness, in both profile bases) and the X carriage is
// not straight along z (in both bases: flatness through the measured traverse, Eq. 16; straightness
// through its polynomial); 0.03 um of profilometer noise.
//   flatness: a bow and an S (1.6 um at 20 mm), the carriage pitching with its guideway's slope, as
//             an autocollimator on it sees it (0.2 arcsec noise per reading).
//   straightness: a bow, 0.8 um at 20 mm.
machine::MachineConfig facing_machine(std::uint64_t seed, bool flatness) {
  machine::MachineConfig m;
  m.name = "explain-facing";
  m.spindle.tilt_x_rad = 5e-6;
  if (flatness) {
    m.axis[0].translation[2].c = {0, 0, 2e-3, 0.1};  // E_ZX = 2e-3 x^2 + 0.1 x^3 (m)
    m.axis[0].bending = true;                        // pitch E_BX = -dE_ZX/dx
    m.noise.autocollimator_rad = 0.2 * pi / 648000;
  } else {
    m.axis[0].translation[2].c = {0, 0, 2e-3};  // E_ZX: 0.8 um at 20 mm
  }
  m.noise.profilometer_m = 0.03 * um;
  m.noise.seed = seed;
  return m;
}

// The X carriage's autocollimator traverse over the faced radius (1 mm feet, mirror midway between
// them), as the format stores it: x = the rear foot, pitch = the chord slope, > 0 rising towards +x
// (minus the rotation about +y). The stations are logged against the machine's displayed X, which
// includes the tool offset (the tool's radius), so with an Abbe arm the carriage sits tool_offset
// behind the label.
AngleTraverse facing_traverse(const machine::Machine& machine, std::uint64_t seed) {
  constexpr double step = 1e-3;
  const double arm = machine.config().tool_offset[0];
  machine::TraverseSpec t;
  t.axis = machine::Axis::x;
  t.start_m = step / 2 - arm;
  t.end_m = 0.02 - step / 2 - arm;
  t.step_m = step;
  t.seed = seed * 1000 + 90;
  AngleTraverse tr;
  tr.source = "scenario-traverse";
  tr.step_m = step;
  for (const auto& st : machine.autocollimator_traverse(t)) {
    tr.x_m.push_back(st.position_m - step / 2 + arm);
    tr.pitch_rad.push_back(-st.pitch_rad);
    tr.line.push_back(tr.x_m.size());
  }
  return tr;
}

std::vector<ProfileRun> facing_runs(const machine::Machine& machine, const std::vector<double>& feeds_mm_per_min,
                                    bool runout_along_path, const ScenarioOptions& o) {
  std::vector<ProfileRun> runs;
  double t0 = 0;
  for (std::size_t k = 0; k < feeds_mm_per_min.size(); ++k) {
    machine::FacingSpec spec;
    spec.x_start_m = 0.0;
    spec.x_end_m = 0.02;
    spec.feed_m_per_s = feeds_mm_per_min[k] / 60000.0;
    spec.spindle_rpm = 107;  // not commensurate with the sampling (110 rpm aliases 2/rev exactly to 0 Hz)
    spec.profile_step_m = o.quick ? 1e-4 : 5e-5;
    spec.t0_s = t0;
    spec.seed = o.seed * 1000 + 100 + k;
    spec.runout_along_path = runout_along_path;
    spec.tool_nose_radius_m = 0.0;
    ProfileRun r;
    r.source = "scenario-profile" + std::to_string(k + 1);
    r.feed_mm_per_min = feeds_mm_per_min[k];
    r.spindle_rpm = spec.spindle_rpm;
    for (const auto& p : machine.facing_profile(spec)) {
      r.x_m.push_back(p.x_m);
      r.z_m.push_back(p.z_m);
      r.t_s.push_back(o.clock_origin_s + p.t_s);
    }
    runs.push_back(std::move(r));
    t0 += 0.02 / spec.feed_m_per_s + 60.0;
  }
  return runs;
}

ScenarioResult profile_scenario(const std::string& name, const ScenarioOptions& o) {
  ScenarioResult s;
  s.name = name;
  s.model = name.rfind("flatness_", 0) == 0 ? "flatness" : "straightness";
  machine::MachineConfig m = facing_machine(o.seed, s.model == "flatness");
  std::vector<double> feeds{2.0, 8.0};
  bool along_path = false;
  if (name == "flatness_thermal_two_feeds" || name == "straightness_thermal_two_feeds") {
    m.axis[2].drift_m_per_s = 0.2 * um / 60.0;
    s.expected = {expect("thermal_drift", results::profile_drift, 0.2, 0.02)};
    s.concealment = s.model == "flatness"
                        ? "Z drift at constant feed: a line in x exactly like squareness; only the 2 and 8 mm/min cuts "
                          "differ (X carriage 1.6 um out of straight, its traverse in the base)"
                        : "Z drift at constant feed: a line in x inside the polynomial base; only the two feeds differ";
  } else if (name == "flatness_spindle_runout") {
    m.spindle.axial_runout_m = 0.1 * um;
    feeds = {2.0};
    along_path = true;
    s.expected = {expect("spindle_axial_runout", results::spindle_axial_runout, 0.1, 0.02)};
    s.concealment =
        "0.1 um twice per revolution (3.6 Hz) sampled every 1.5-3 s along the tool path: aliased into "
        "slow waviness";
  } else if (name == "flatness_abbe_offset") {
    m.tool_offset = {3e-3, 0, 0};
    // u is 0.12-0.17 mm from the profiles alone; the traverse's noise (common to both cuts, not in u) adds
    // about as much again: hence 0.5 mm.
    s.expected = {expect("abbe_offset", results::abbe_offset, 3.0, 0.5)};
    s.concealment =
        "the tool 3 mm along x from the carriage point the traverse measured: pitch x 3 mm adds up to "
        "0.6 um, all but its curvature a line in x like squareness; what is left is the size of the 0.03 um "
        "noise";
  } else if (name == "flatness_null" || name == "straightness_null") {
    s.concealment = s.model == "flatness"
                        ? "nothing left out: squareness, the X carriage's straightness (its traverse "
                          "in the base, abbe_offset tried) and 0.03 um noise, two feeds"
                        : "nothing left out: squareness, a bowed X carriage and 0.03 um noise, two feeds";
  } else {
    throw std::invalid_argument("unknown scenario: " + name);
  }
  const machine::Machine machine(m);
  std::optional<AngleTraverse> traverse;
  if (s.model == "flatness") traverse = facing_traverse(machine, o.seed);
  s.report = models::explain::explain(
      profile_problem(facing_runs(machine, feeds, along_path, o), s.model, traverse ? &*traverse : nullptr), o.explain);
  evaluate(s);
  return s;
}

}  // namespace

void check_expectations(ScenarioResult& s) { evaluate(s); }

std::vector<std::string> scenario_names() {
  std::vector<std::string> out;
  for (const auto& s : dbb_scenarios()) out.push_back(s.name);
  for (const char* p : {"flatness_thermal_two_feeds", "flatness_spindle_runout", "flatness_abbe_offset",
                        "flatness_null", "straightness_thermal_two_feeds", "straightness_null"})
    out.emplace_back(p);
  for (auto& n : runout_scenario_names()) out.push_back(std::move(n));
  for (auto& n : traverse_scenario_names()) out.push_back(std::move(n));
  return out;
}

ScenarioResult run_scenario(const std::string& name, const ScenarioOptions& options) {
  if (const DbbScenario* d = find_dbb(name)) return dbb_scenario(*d, options);
  if (name.rfind("flatness_", 0) == 0 || name.rfind("straightness_", 0) == 0) return profile_scenario(name, options);
  if (name.rfind("runout_", 0) == 0) return runout_scenario(name, options);
  if (name.rfind("traverse_", 0) == 0) return traverse_scenario(name, options);
  throw std::invalid_argument("unknown scenario: " + name);
}

std::vector<formats::DbbRun> scenario_dbb_runs(const std::string& name, const ScenarioOptions& options) {
  const DbbScenario* d = find_dbb(name);
  if (!d) throw std::invalid_argument("not a DBB scenario: " + name);
  machine::MachineConfig m = dbb_machine(options.seed);
  d->inject(m);
  return dbb_runs(m, *d, options);
}

ScenarioSummary summarize_scenario(const std::string& name, const std::vector<std::uint64_t>& seeds,
                                   const ScenarioOptions& options) {
  ScenarioSummary out;
  out.name = name;
  out.seeds = seeds;
  for (const std::uint64_t seed : seeds) {
    ScenarioOptions o = options;
    o.seed = seed;
    out.runs.push_back(run_scenario(name, o));
    out.passed += out.runs.back().pass ? 1 : 0;
  }
  if (!out.runs.empty()) {
    out.model = out.runs.front().model;
    out.concealment = out.runs.front().concealment;
    out.expected = out.runs.front().expected;
    out.expect_unexplained = out.runs.front().expect_unexplained;
  }
  return out;
}

Coverage uncertainty_coverage(const std::vector<ScenarioSummary>& summaries) {
  Coverage c;
  std::size_t one = 0, two = 0;
  for (const auto& s : summaries)
    for (const auto& r : s.runs)
      for (const auto& k : r.checks) {
        if (!k.found || !std::isfinite(k.u) || !(k.u > 0)) continue;
        const double z = std::abs(k.value - k.expected.truth) / k.u;
        ++c.n;
        one += z <= 1 ? 1 : 0;
        two += z <= 2 ? 1 : 0;
      }
  if (c.n > 0) {
    c.within_1u = static_cast<double>(one) / static_cast<double>(c.n);
    c.within_2u = static_cast<double>(two) / static_cast<double>(c.n);
  }
  return c;
}

std::string scenario_table_markdown(const std::vector<ScenarioSummary>& summaries) {
  std::ostringstream o;
  o << "| scenario | injected (how it hides) | parameter: truth | found (seeds) | mean +/- sd over seeds | mean u | "
       "max abs(error)/u | held-out RMS before / after (um, mean) | unexplained (seeds) | pass |\n";
  o << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& s : summaries) {
    const double k = static_cast<double>(s.runs.size());
    double before = 0, after = 0;
    std::size_t unexplained = 0;
    std::vector<std::string> extras;
    for (const auto& r : s.runs) {
      before += r.report.baseline.heldout_rms_um / k;
      after += r.report.final_fit.heldout_rms_um / k;
      unexplained += r.report.unexplained ? 1 : 0;
      for (const auto& e : r.extra)
        if (std::find(extras.begin(), extras.end(), e) == extras.end()) extras.push_back(e);
    }
    const std::string seeds = std::to_string(s.runs.size());
    const std::string common = printf_number("%.4f", before) + " / " + printf_number("%.4f", after) + " | " +
                               std::to_string(unexplained) + "/" + seeds + (s.expect_unexplained ? " (expected)" : "") +
                               " | " + std::to_string(s.passed) + "/" + seeds + " |";
    std::string extra_note;
    for (const auto& e : extras) extra_note += (extra_note.empty() ? "; also found: " : ", ") + e;
    if (!s.expected.empty() && !s.runs.empty() && !s.runs.front().expect_where.empty())
      extra_note += "; set aside: " + s.runs.front().located + " (seed " + std::to_string(s.seeds.front()) +
                    "; expected " + s.runs.front().expect_where + ")";
    if (s.expected.empty()) {
      std::string found = s.expect_unexplained ? "outside the library" : "none";
      std::size_t with = 0;
      for (const auto& r : s.runs) with += r.report.findings.empty() ? 0 : 1;
      o << "| " << s.name << " | " << s.concealment << " | " << found << " | findings in " << with << "/" << seeds
        << extra_note;
      if (!s.runs.empty() && !s.runs.front().expect_where.empty())
        o << "; located at " << s.runs.front().located << " (seed " << s.seeds.front() << "; expected "
          << s.runs.front().expect_where << ")";
      o << " | - | - | - | " << common << "\n";
      continue;
    }
    for (std::size_t e = 0; e < s.expected.size(); ++e) {
      const Expectation& x = s.expected[e];
      std::size_t found = 0;
      double mean = 0, u_mean = 0, zmax = 0;
      std::size_t with_u = 0;
      std::vector<double> values;
      for (const auto& r : s.runs) {
        const Check& c = r.checks[e];
        if (!c.found) continue;
        ++found;
        values.push_back(c.value);
        if (std::isfinite(c.u) && c.u > 0) {
          u_mean += c.u;
          ++with_u;
          zmax = std::max(zmax, std::abs(c.value - x.truth) / c.u);
        }
      }
      for (double v : values) mean += v / static_cast<double>(values.size());
      double sd = 0;
      for (double v : values) sd += (v - mean) * (v - mean);
      sd = values.size() > 1 ? std::sqrt(sd / static_cast<double>(values.size() - 1)) : nan;
      const std::string stat =
          values.empty() ? "-"
                         : printf_number("%.4g", mean) + (std::isfinite(sd) ? " +/- " + printf_number("%.2g", sd) : "");
      const std::string u = with_u ? printf_number("%.2g", u_mean / static_cast<double>(with_u)) : "-";
      const std::string z = with_u ? printf_number("%.2g", zmax) : "-";
      o << "| " << (e == 0 ? s.name : "") << " | " << (e == 0 ? s.concealment : "") << " | " << x.effect << ": "
        << x.parameter << " = " << printf_number("%.4g", x.truth) << " (+/- " << printf_number("%.3g", x.tolerance)
        << ") | " << found << "/" << seeds << (e == 0 ? extra_note : "") << " | " << stat << " | " << u << " | " << z
        << " | " << (e == 0 ? common : " | | |") << "\n";
    }
  }
  const Coverage c = uncertainty_coverage(summaries);
  o << "\nUncertainty coverage: of " << c.n << " fitted parameters, " << printf_number("%.0f", 100 * c.within_1u)
    << " % within 1 u and " << printf_number("%.0f", 100 * c.within_2u)
    << " % within 2 u of the truth (68 % and 95 % for honest standard uncertainties).\n";
  return o.str();
}

}  // namespace guideway::simulators::scenarios
