#pragma once
// The virtual machine tool: one 3-axis machine with configurable geometric, servo, mechanical,
// thermal and noise errors. Every emulated instrument asks it what it would see, so a DBB circle, an
// autocollimator traverse, a micrometer run-out revolution and a faced profile from one machine are
// mutually consistent. Instrument readings are computed from exact homogeneous transforms of the
// kinematic chain (bed -> Y carriage -> X carriage -> Z carriage -> tool point; no small-angle
// truncation) and exact bar geometry, never from the linearised signatures used by identification.
//
// Units: SI everywhere in this API (metres, radians, seconds); the TOML file uses units in key names
// (docs/machine.md). Thread safety: a Machine is immutable after construction; all queries are const
// and may run concurrently. Each query draws its noise from its own RNG seeded from `seed` (0 = the
// machine's [noise] seed), so a query with the same arguments returns bit-identical results.

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "formats/dbb_run.hpp"
#include "simulators/machine/noise.hpp"

namespace guideway::simulators::machine {

using Vec3 = std::array<double, 3>;  // x, y, z in metres (machine coordinates)

enum class Axis : int { x = 0, y = 1, z = 2 };

// Polynomial in the axis position u (metres from machine zero): sum_k c[k] u^k.
struct Polynomial {
  std::vector<double> c;
  [[nodiscard]] double operator()(double u) const noexcept;
  [[nodiscard]] double derivative(double u) const noexcept;
  [[nodiscard]] bool empty() const noexcept { return c.empty(); }
};

// The errors of one linear axis (ISO 230-1 style: for axis j the translation error motions
// E_Xj, E_Yj, E_Zj and the rotation error motions E_Aj, E_Bj, E_Cj about x, y, z), plus its servo,
// mechanical, thermal and sensor effects. All fields default to a perfect axis.
struct AxisErrors {
  // Geometric, functions of the axis position u (m).
  double scale = 0.0;                     // relative: actual travel = (1 + scale) * commanded (from machine zero)
  std::array<Polynomial, 3> translation;  // E_Xj(u), E_Yj(u), E_Zj(u) in m (the one along j adds to positioning)
  std::array<Polynomial, 3> rotation;     // E_Aj(u), E_Bj(u), E_Cj(u) in rad, right-handed about +x, +y, +z
  // When true the two rotations perpendicular to j also follow the slope of the straightness curves
  // (guideway bending, Lai Eqs. 1-9): e.g. for X, E_CX += atan(dE_YX/dx), E_BX -= atan(dE_ZX/dx).
  bool bending = false;

  // Servo and mechanical.
  double servo_lag_s = 0.0;       // first-order position loop time constant (1/Kv); mismatch = lag_x - lag_y
  double backlash_m = 0.0;        // lost motion: actual = servo - (b/2) sign(velocity), deadband model
  double reversal_spike_m = 0.0;  // at a reversal the axis sticks: error -sign(v_new) * A * exp(-dt/decay)
  double reversal_spike_decay_s = 0.02;
  // Stick-slip: after a reversal the axis jerks, -sign(v_new) * A * exp(-dt/decay) * sin(2 pi f dt).
  double stick_slip_m = 0.0;
  double stick_slip_hz = 10.0;
  double stick_slip_decay_s = 0.1;
  double lateral_play_m = 0.0;      // carriage shifts sideways by (p/2) sign(velocity) (X->y, Y->x, Z->x)
  double cyclic_amplitude_m = 0.0;  // lead-screw error: + A sin(2 pi u / period + phase)
  double cyclic_period_m = 0.005;
  double cyclic_phase_rad = 0.0;
  // A periodic pitch of the carriage as it runs over a rack or a lead screw's long wave: the rotation about
  // the axis' pitch axis (X: y, Y: x, Z: y) gains A sin(2 pi u / period + phase).
  double pitch_wave_rad = 0.0;
  double pitch_wave_period_m = 0.1;
  double pitch_wave_phase_rad = 0.0;
  double yaw_wave_rad = 0.0;  // the same about the yaw axis (X, Y: z; Z: x)
  double yaw_wave_period_m = 0.1;
  double yaw_wave_phase_rad = 0.0;

  // Thermal (t = machine time in s since the start of the warm-up, see the queries' t0_s).
  double scale_drift_per_s = 0.0;  // d(scale)/dt
  double drift_m_per_s = 0.0;      // position drift along the axis

  // A local bump on the guideway (a dent, a chip under the rail): the carriage is displaced along
  // `bump_direction` (0 = x, 1 = y, 2 = z; not the axis itself) by A exp(-(u - c)^2 / (2 w^2)).
  // Nothing in the identification models describes it (the explain scenarios' out-of-library cause).
  double bump_amplitude_m = 0.0;
  double bump_center_m = 0.0;
  double bump_width_m = 0.005;
  int bump_direction = 1;

  // Vibration of the carriage along its own axis and the controller's encoder.
  double vibration_amplitude_m = 0.0;
  double vibration_frequency_hz = 0.0;
  double encoder_resolution_m = 0.0;  // quantisation of the encoder reading (0 = none)
  double encoder_noise_m = 0.0;       // standard deviation of white noise on the encoder reading
};

// The error motions of axis j (0 x, 1 y, 2 z) at position u (m) and machine time t: the translations E_Xj,
// E_Yj, E_Zj (m; the one along j is the positioning error, u (scale + scale drift t) + E_jj(u) + drift t, the
// bump in its direction) and the rotations E_Aj, E_Bj, E_Cj (rad; with the pitch and yaw waves and, for a
// bent guideway, the straightness slopes). What the chain applies; not the servo, backlash or cyclic error.
std::array<double, 6> axis_error_motions(const AxisErrors& e, int j, double u, double t_s = 0.0);

// Squareness between axes (rad). xy: the actual Y travel direction leans towards +x, so actual
// (x, y) = (x + q y, y) to first order; xz: Z leans towards +x (x += q z); yz: Z leans towards +y.
struct Squareness {
  double xy = 0.0;
  double xz = 0.0;
  double yz = 0.0;
};

// DBB set-up errors and the bar as a sensor.
struct DbbErrors {
  // Centre of the traced circle (of the tool point: the commanded centre plus the tool offset) minus the
  // fixed-ball projection (m).
  std::array<double, 3> center_offset{};
  double bar_length_error_m = 0.0;        // calibration error of the bar's nominal length
  double bar_drift_m_per_s = 0.0;         // thermal growth of the reading (positive = reads longer)
  double noise_m = 0.0;                   // standard deviation of the bar reading
  // The transducer is not linear: it reads dL + q dL^2 + c dL^3 (dL from the nominal length, in m).
  double nonlinearity_quadratic_per_m = 0.0;
  double nonlinearity_cubic_per_m2 = 0.0;
  // A mounting failure: at machine time slip_time_s the ball slips in its socket and the reading steps
  // by slip_m from then on (0 = none).
  double slip_m = 0.0;
  double slip_time_s = 0.0;
};

struct SpindleErrors {
  double tilt_x_rad = 0.0;      // spindle axis leans towards +x (squareness to the X travel, Mu's Delta beta_xz)
  double tilt_y_rad = 0.0;      // towards +y
  double axial_runout_m = 0.0;  // twice-per-revolution axial motion amplitude
  // The run-out test's thrust plate (stationary, on the table) is not parallel to the X/Y travel: its
  // normal leans by this angle towards the azimuth `plate_parallelism_direction` (0 = towards +x, as
  // tilt_x). Mu's p of Eq. 21 is this angle times the plate diameter.
  double plate_parallelism_rad = 0.0;
  double plate_parallelism_direction_rad = 0.0;
  // ISO 230-7 error motions the run-out probe sees along the spindle axis, on top of the lean:
  // synchronous harmonics (integer orders, the same every revolution: bearing race waviness, artifact
  // form) and asynchronous lines (non-integer orders: a rolling element's defect, cage frequency), each
  // amplitude * cos(order * theta + phase), theta the spindle's angle since the record began.
  struct Line {
    double order = 0.0;
    double amplitude_m = 0.0;
    double phase_rad = 0.0;
  };
  std::vector<Line> synchronous;
  std::vector<Line> asynchronous;
  double axial_growth_m_per_s = 0.0;  // thermal growth of the spindle along its axis during the record
  // The thrust plate's own form (its lobing): lines of integer order in the plate's azimuth, adding to
  // its height under the probe. It turns with the plate (RunoutSpec::artifact_turned_rad), the spindle's
  // error motions above do not: what a reversal (Donaldson) separates.
  std::vector<Line> plate_form;
  // The spindle's speed drifts and ripples: rpm(t) = rpm (1 + speed_ramp_per_s t + speed_ripple
  // sin(2 pi f t)), f = speed_ripple_per_rev rpm / 60 (a drive's frequency in cycles per nominal
  // revolution), so a reading taken at time t is at theta = omega (t + speed_ramp_per_s t^2 / 2 +
  // speed_ripple (1 - cos(2 pi f t)) / (2 pi f)), not at the nominal omega t.
  double speed_ramp_per_s = 0.0;
  double speed_ripple = 0.0;  // amplitude, a fraction of the nominal speed
  double speed_ripple_per_rev = 0.0;
};

// The autocollimator and its set-up, as its traverse readings see them (docs/formats.md's signs: a reading
// is the slope, > 0 rising towards +x): the instrument's zero or the air drifts in time, the reflector
// rocks on its mount with the direction of travel, and a head turned about its beam reads part of the yaw
// as pitch.
struct AutocollimatorErrors {
  double pitch_drift_rad_per_s = 0.0;  // both channels' zero drift, from machine time 0
  double yaw_drift_rad_per_s = 0.0;
  double rocking_rad = 0.0;  // the pitch reading gains + rocking moving +, - rocking moving -
  // pitch read = pitch cos r + yaw sin r, yaw read = yaw cos r - pitch sin r
  double head_roll_rad = 0.0;
};

struct SensorNoise {
  std::uint64_t seed = 1;
  double autocollimator_rad = 0.0;  // standard deviation per reading
  double micrometer_m = 0.0;
  double profilometer_m = 0.0;
  double position_m = 0.0;  // white vibration of the tool point (all three directions)
};

// A controller's per-joint compensation table, as LinuxCNC applies one (COMP_FILE_TYPE = 0): at each
// nominal joint position, the actual position the joint reaches moving + and moving -. The controller
// adds nominal - actual, interpolated linearly, to the commanded joint position, chosen by the sign of
// the commanded velocity (the last sign is kept while the joint stands still), so the actual position
// reaches the nominal. Outside the table the end values hold. Empty = no compensation.
struct JointCompensation {
  std::vector<double> nominal_m;  // strictly ascending
  std::vector<double> forward_m;  // actual position moving +
  std::vector<double> reverse_m;  // moving -
  [[nodiscard]] bool empty() const noexcept { return nominal_m.empty(); }
  // What the controller adds to the commanded position (m) moving in `direction` (+1 / -1).
  [[nodiscard]] double correction_m(double commanded_m, int direction) const noexcept;
};

// A controller's cross-axis (straightness) correction: the command of joint `corrected` gets
// correction_m interpolated linearly in joint `moving`'s commanded position (end values hold outside),
// as a controller's straightness / cross compensation applies it.
struct CrossCompensation {
  Axis moving = Axis::x;
  Axis corrected = Axis::y;
  std::vector<double> nominal_m;     // strictly ascending positions of `moving`
  std::vector<double> correction_m;  // added to `corrected`'s command
  [[nodiscard]] double at(double moving_commanded_m) const noexcept;
};

// What the controller corrects: an axis-skew correction of the squareness (applied first, as a
// controller's skew option or kinematics would: commanded x -= xy * y + xz * z, y -= yz * z, with the
// signs of Squareness), the cross-axis corrections (indexed by the commanded positions, before the
// skew), then the per-joint tables (by axis x, y, z; last, on the joint commands).
struct ControllerCorrection {
  std::array<JointCompensation, 3> tables;
  Squareness skew;
  std::vector<CrossCompensation> cross;
  // A volumetric compensation (Siemens VCS, Heidenhain KinematicsComp, a map of the 21 errors; applied first):
  // the correction (m) added to the commanded position, a function of it. Empty: none.
  std::function<Vec3(const Vec3&)> volumetric;
};

// The motor commands the controller gives for commanded position `c` with `correction` (volumetric, then
// skew, cross-axis and per-joint tables; the tables' column by `direction` of each joint, +1 / -1).
Vec3 controller_command(const ControllerCorrection& correction, const Vec3& c, const std::array<int, 3>& direction);

struct MachineConfig {
  std::string name = "virtual";
  std::array<AxisErrors, 3> axis;  // indexed by Axis
  Squareness squareness;
  DbbErrors dbb;
  SpindleErrors spindle;
  AutocollimatorErrors autocollimator;
  SensorNoise noise;
  Vec3 tool_offset{};  // tool point in the Z carriage frame at zero (m); non-zero gives Abbe arms
  // The controller's corrections (not part of a machine file; machine::remeasure_dbb loads them); they act
  // in simulate_motion and so in every dynamic query.
  ControllerCorrection controller;
};

// Parses a machine file (docs/machine.md). Errors are guideway::ConfigError "file:line: key: message";
// unknown keys are rejected.
MachineConfig load_machine_config(const std::string& path);
MachineConfig parse_machine_config(std::string_view toml_text, const std::string& file_name);
// config/machine-example.toml, compiled in: the machine every emulator uses unless given --machine,
// so emulated instruments started separately still agree with each other.
MachineConfig default_machine_config();

// One instant of a motion.
struct MotionSample {
  double t_s = 0.0;    // machine time
  Vec3 commanded{};    // what the controller commands (m), before its compensation tables
  Vec3 encoder{};      // what the controller reads from its axis encoders (lagging servo position, quantised)
  Vec3 axis_actual{};  // axis positions after backlash, cyclic error, spikes, vibration (before geometry;
                       // scale, thermal drift and the error motions are applied by the chain)
  Vec3 tool{};         // actual tool point in machine coordinates, through the exact HTM chain
};

// A commanded path: position (m) as a function of the time since the start of the motion (s).
using CommandedPath = std::function<Vec3(double)>;

struct MotionSpec {
  CommandedPath path;
  double duration_s = 0.0;
  double sample_rate_hz = 1000.0;
  double t0_s = 0.0;       // machine time at the start (thermal drift)
  std::uint64_t seed = 0;  // 0 = the machine's noise seed
};

enum class Plane { xy, xz, yz };

// A DBB circular test: the tool ball runs a circle of `radius` about `center` in `plane`; the fixed
// ball sits `height` below it along the plane normal (Lai's h) and off by the configured centre
// offset. The commanded angle runs from start - overshoot to start + data arc + overshoot (ccw) or
// the mirror image (cw); samples inside the data arc (360 deg, or a partial arc such as the 220 deg a
// vertical plane allows: from -20 to 200 deg ccw, from 200 to -20 deg cw) are flagged.
struct DbbCircleSpec {
  double radius_m = 0.1;
  double height_m = 0.0;
  formats::DbbDirection direction = formats::DbbDirection::ccw;
  Plane plane = Plane::xy;
  double feed_m_per_s = 1000.0 / 60000.0;     // 1000 mm/min
  double start_angle_rad = 0.0;               // where the data arc starts
  double data_arc_rad = 6.283185307179586;    // the arc the samples are taken on (2 pi: a full circle)
  double overshoot_rad = 0.7853981633974483;  // 45 deg feed-in and feed-out arcs
  double sample_rate_hz = 0.0;                // 0 = 10 samples per degree of arc
  Vec3 center{};                              // commanded circle centre (machine coordinates)
  double t0_s = 0.0;
  std::uint64_t seed = 0;
};

struct DbbSample {
  double t_s = 0.0;
  double angle_rad = 0.0;  // commanded angle zeta, from the first plane axis towards the second
  bool in_data_arc = false;
  Vec3 tool{};     // actual tool-ball centre
  Vec3 encoder{};  // controller's axis encoder readings
  Vec3 commanded{};
  double bar_length_m = 0.0;  // reading of the bar (with noise and drift)
  double dL_m = 0.0;          // bar_length - nominal length sqrt(r^2 + h^2)
};

struct DbbRun {
  DbbCircleSpec spec;
  double nominal_length_m = 0.0;
  std::vector<DbbSample> samples;  // the whole motion, overshoot arcs included
};

// Autocollimator traverse: the machine stops every `step` along `axis`; the mirror is on the moving
// carriage (for X and Y on the tool side, so it sees the rotations of all carriages below), the
// autocollimator beam is along the axis. Angles are the mirror's exact rotations about the two
// axes perpendicular to the beam.
struct TraverseSpec {
  Axis axis = Axis::x;
  double start_m = 0.0;
  double end_m = 0.6;
  double step_m = 0.01;
  Vec3 other{};          // position of the other axes
  double dwell_s = 1.0;  // time per station (thermal drift)
  double t0_s = 0.0;
  std::uint64_t seed = 0;
};

struct TraverseStation {
  double t_s = 0.0;
  double position_m = 0.0;  // commanded position along the axis
  double pitch_rad = 0.0;   // X: about y; Y: about x; Z: about y
  double yaw_rad = 0.0;     // X and Y: about z; Z: about x
  Vec3 tool{};              // actual tool point at the station
};

// Mu's run-out test (Sec. 4, Fig. 10): an inductance micrometer carried by the spindle at radius
// `probe_radius` touches a stationary thrust plate; reading = gap along the spindle axis versus spindle
// angle (0 = probe on the +x side). It sees the spindle's lean relative to the plate, so Eq. 21 adds
// the plate's own parallelism p back to recover the lean against the travel.
struct RunoutSpec {
  double probe_radius_m = 0.5;
  std::size_t samples_per_rev = 360;
  double rpm = 10.0;
  std::size_t revolutions = 1;
  double t0_s = 0.0;
  std::uint64_t seed = 0;
  // The plate turned on the table about the spindle axis since the first record, in the direction the
  // spindle turns (180 deg: Donaldson's reversal): its form is read at plate azimuth theta - turned.
  double artifact_turned_rad = 0.0;
};

struct RunoutSample {
  double t_s = 0.0;
  double angle_rad = 0.0;
  double displacement_m = 0.0;  // height of the plate surface under the probe along +z (positive = pushes the probe)
};

// Facing cut on a lathe (Mu's experiment): the tool traverses X from x_start to x_end at constant
// feed with the spindle turning; the faced surface height along the radius is the tool's axial
// position through the exact chain plus the feed marks of a round-nosed tool; the profile is then
// measured along +x every `profile_step`.
struct FacingSpec {
  double x_start_m = 0.0;
  double x_end_m = 0.6;
  double z_m = 0.0;                     // commanded Z during the cut
  double feed_m_per_s = 2.0 / 60000.0;  // 2 mm/min
  double spindle_rpm = 100.0;
  double tool_nose_radius_m = 0.0008;
  double profile_step_m = 0.0005;
  double t0_s = 0.0;
  std::uint64_t seed = 0;
  // true: the profile is taken along the tool's path while cutting (an in-process probe), so each point
  // also carries the spindle's axial motion at that moment, SpindleErrors::axial_runout_m cos(2 theta),
  // theta = 2 pi rpm / 60 t. false (default): a radial line of the finished face.
  bool runout_along_path = false;
};

struct ProfilePoint {
  double x_m = 0.0;  // radial position along the profile
  double z_m = 0.0;  // surface height along the spindle axis (profilometer reading, with noise)
  double t_s = 0.0;  // machine time when the tool cut this radius
};

// Wei's 1-D artifact: targets every `pitch` along `axis`, measured with the probe carried by the
// machine: deviation of each target's measured position and angles from their calibration.
struct ArtifactSpec {
  Axis axis = Axis::x;
  double start_m = 0.0;
  double pitch_m = 0.05;
  std::size_t targets = 9;
  Vec3 other{};
  double t0_s = 0.0;
  std::uint64_t seed = 0;
};

struct ArtifactTarget {
  double nominal_m = 0.0;
  Vec3 displacement_m{};  // tool point actual minus commanded (the six error functions' translations)
  Vec3 rotation_rad{};    // rotations of the carriage about x, y, z
};

class Machine {
 public:
  explicit Machine(MachineConfig config);
  static Machine from_file(const std::string& path) { return Machine(load_machine_config(path)); }

  [[nodiscard]] const MachineConfig& config() const noexcept { return config_; }

  // Exact geometry, no servo: actual tool point for the given (post-servo) axis positions at time t.
  [[nodiscard]] Vec3 tool_point(const Vec3& axis_position, double t_s = 0.0) const;
  // Orientation of the carriage of `axis` (and everything it carries) in machine coordinates,
  // row-major 3x3 rotation.
  [[nodiscard]] std::array<double, 9> carriage_rotation(Axis axis, const Vec3& axis_position) const;

  // Any commanded motion sampled in time: servo lag, backlash, spikes, lateral play, cyclic error,
  // drift, vibration, encoder quantisation and the exact chain.
  [[nodiscard]] std::vector<MotionSample> simulate_motion(const MotionSpec& spec) const;

  [[nodiscard]] DbbRun dbb_circle(const DbbCircleSpec& spec) const;
  [[nodiscard]] std::vector<TraverseStation> autocollimator_traverse(const TraverseSpec& spec) const;
  // Passes back and forth: `spec` is the first (forward) pass, the next runs from its end back to its start,
  // and so on, each starting turn_s after the last reading of the one before; pass k's noise seed is
  // spec's seed (or the machine's) + k.
  [[nodiscard]] std::vector<std::vector<TraverseStation>> autocollimator_passes(const TraverseSpec& spec,
                                                                                std::size_t passes,
                                                                                double turn_s) const;
  // Readings at times t0 + k T / samples_per_rev (T = 60 / rpm), k < samples_per_rev * revolutions;
  // the angle is where the spindle is at that time (its speed may drift).
  [[nodiscard]] std::vector<RunoutSample> runout_revolution(const RunoutSpec& spec) const;
  // Reading k of that record alone (the emulator's endless stream), its noise drawn from (seed, k).
  [[nodiscard]] RunoutSample runout_sample(const RunoutSpec& spec, std::uint64_t k) const;
  [[nodiscard]] std::vector<ProfilePoint> facing_profile(const FacingSpec& spec) const;
  [[nodiscard]] std::vector<ArtifactTarget> artifact_measurement(const ArtifactSpec& spec) const;
  // The tool point (machine coordinates, m) with the axes standing at `motor` positions approached in the
  // direction of `approach` (+1 / -1 per axis: half the backlash behind), with their cyclic error, through
  // the exact chain at machine time t: what a static measurement (an artifact, a laser) sees.
  [[nodiscard]] Vec3 static_tool_point(const Vec3& motor, const std::array<int, 3>& approach = {1, 1, 1},
                                       double t_s = 0.0) const;

 private:
  MachineConfig config_;
};

// The servo, the mechanics and the chain of a machine advanced step by step by its drives' commands (the
// motor positions a controller sends its drives, its compensation included): what simulate_motion runs
// along a commanded path, and what follows a real controller's servo periods (guideway-emulate dbb
// --follow: LinuxCNC's joint motor-pos-cmd). Holds a reference to the machine, which must outlive it. Not
// thread safe.
class MotionStepper {
 public:
  // Standing at `motor_m` (the drives at rest there) at machine time t0_s; noise drawn from `seed` (0: the
  // machine's noise seed).
  MotionStepper(const Machine& machine, const Vec3& motor_m, double t0_s, std::uint64_t seed);
  // Advances to time t_rel_s (since t0), dt_s after the last step, the drives' command moving linearly to
  // motor_m over the step (a first-order lag answers a ramp exactly).
  void step(const Vec3& motor_m, double t_rel_s, double dt_s);
  // The machine now, at t_rel_s (since t0): its encoders, axes and tool point; `commanded_m` is what the
  // controller commanded (reported as given). Draws the sample's noise.
  [[nodiscard]] MotionSample sample(const Vec3& commanded_m, double t_rel_s);

 private:
  const Machine* machine_;
  Rng rng_;
  double t0_s_ = 0.0;
  Vec3 motor_{};
  Vec3 servo_{};
  Vec3 backlash_{};  // position after the backlash deadband
  int dir_[3] = {0, 0, 0};
  double t_rev_[3] = {-1e30, -1e30, -1e30};
  int spike_sign_[3] = {0, 0, 0};
};

// The ball bar as a sensor: what it reads of the distance between the tool ball and the fixed ball, with the
// bar's own errors (DbbErrors: nonlinearity, length error, thermal drift, a slip, noise). Not thread safe.
class DbbBar {
 public:
  // Noise drawn from `seed` (0: the machine's noise seed).
  DbbBar(const MachineConfig& config, const Vec3& fixed_ball_m, double nominal_length_m, std::uint64_t seed);
  // The reading (m) with the tool ball at tool_m at machine time t_s.
  [[nodiscard]] double read(const Vec3& tool_m, double t_s);

 private:
  DbbErrors errors_;
  Vec3 fixed_{};
  double nominal_m_ = 0.0;
  Rng rng_;
};

// Where the fixed ball sits for a circle about `center_m` in `plane` with the tool ball `height_m` above it
// (Lai's h): the centre less the set-up's offset (DbbErrors::center_offset), h below along the plane normal.
Vec3 dbb_fixed_ball(const MachineConfig& config, const Vec3& center_m, Plane plane, double height_m);

// Helpers for commanded paths.
CommandedPath linear_move(const Vec3& from, const Vec3& to, double feed_m_per_s);

}  // namespace guideway::simulators::machine
