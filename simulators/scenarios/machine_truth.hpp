#pragma once
// What a test on the virtual machine tool can find (the emulators' machine, our own, so its errors are
// known): per effect of the explanation library the parameter it would report and the machine file's
// value, and what the machine holds that the test cannot observe, with the reason and the size it would
// have in the reading. A DBB test (the bar), a spindle run-out record (the micrometer on the thrust
// plate) and an autocollimator traverse. `guideway explain --machine FILE` prints it beside the findings. Pure
// functions; thread safe.

#include <string>
#include <vector>

#include "simulators/machine/machine.hpp"

namespace guideway::simulators::scenarios {

// One DBB run of the test, as PARAMS (`runs`) or a run file describes it.
struct TruthRun {
  double radius_m = 0.1;
  double height_m = 0.0;
  int direction = 1;  // +1 ccw, -1 cw
  double feed_m_per_s = 0.0;
  double sample_rate_hz = 0.0;  // 0 = unknown
};

struct TruthItem {
  std::string effect;     // as EXPLAIN names it
  std::string parameter;  // as EXPLAIN reports it
  double value = 0.0;     // the machine file's, in the parameter's unit
  std::string note;       // e.g. "period 4 mm", "two radii needed"
  double order = 0.0;     // a run-out line's order per revolution (the finding's order_per_rev); 0: none
};

struct Unobservable {
  std::string what;  // the machine file's entry, with its value
  std::string why;   // why this test cannot see it, with the size it would have (um) where it has one
};

struct MachineTruth {
  std::vector<TruthItem> findable;
  // Lai's base as the ballbar diagnostics report it (PARAMS' "diagnostics", `guideway identify dbb`): the
  // geometric terms every test with an h = 0 ccw/cw pair fits, whatever EXPLAIN finds. `parameter` is
  // the diagnostics' name (a centre offset's without its run: each run has one, the machine's).
  std::vector<TruthItem> diagnostics;
  std::vector<Unobservable> unobservable;
  std::string note;  // what the comparison assumes (the base, the noise)
  // The sign of the centre offset, one sentence: PARAMS' against the machine file's and Lai's e_x/e_y.
  std::string centre_offset_sign;
};

// plane "xy", "xz" or "yz"; angles_from_encoders: the runs' angles are the axis encoders' (a live
// session) rather than the commanded ones (simulated runs, a ballbar's time-based angles).
MachineTruth dbb_truth(const machine::MachineConfig& machine, const std::string& plane,
                       const std::vector<TruthRun>& runs, bool angles_from_encoders);

// One run-out record of the test: its spindle speed and length.
struct TruthRecord {
  double rpm = 60.0;
  double revolutions = 20.0;
  double samples_per_rev = 50.0;
};

// The spindle's error motions a run-out record sees (the runout session's micrometer on the thrust plate;
// models/explain/runout_explain): the synchronous harmonics (the twice-per-revolution axial run-out, the
// [spindle] harmonics and the plate's form, together), the asynchronous lines, the axial growth, the speed
// ramp and ripple, each as EXPLAIN reports
// it (in the reading's sign: the plate's height under the probe); the lean against the plate is the base.
MachineTruth runout_truth(const machine::MachineConfig& machine, const std::vector<TruthRecord>& records);

// The autocollimator's errors a straightness traverse of the X axis sees (the emulator's traverse; the
// straightness session's forward and return passes; models/explain/traverse_explain), each as EXPLAIN reports
// it in the slope's sign: the pitch reading's drift in time, the reflector's rocking with the direction of
// travel, X's periodic pitch, the head's roll (the yaw read as pitch); the axis's pitch polynomial is the base.
MachineTruth traverse_truth(const machine::MachineConfig& machine);

}  // namespace guideway::simulators::scenarios
