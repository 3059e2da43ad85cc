#pragma once
// What a DBB test on the virtual machine tool can find (the emulators' machine, our own, so its errors
// are known): per effect of the explanation library the parameter it would report and the machine
// file's value, and what the machine holds that the test cannot observe, with the reason and the size
// it would have in the bar's reading. `guideway explain --machine FILE` prints it beside the findings.
// Pure functions; thread safe.

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
};

struct Unobservable {
  std::string what;  // the machine file's entry, with its value
  std::string why;   // why this test cannot see it, with the size it would have (um) where it has one
};

struct DbbTruth {
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
DbbTruth dbb_truth(const machine::MachineConfig& machine, const std::string& plane, const std::vector<TruthRun>& runs,
                   bool angles_from_encoders);

}  // namespace guideway::simulators::scenarios
