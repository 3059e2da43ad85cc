#pragma once
// DBB runs from the virtual machine tool, in the run-file form the identification reads (only the
// data arc, 360 deg or the spec's partial arc, stated as data_arc_deg; overshoot arcs are dropped), and the virtual
// machine under a controller's compensation tables (LinuxCNC files, as `guideway compensate --verify` proves them).
// Thread safe.

#include <string>
#include <vector>

#include "formats/compensation_files.hpp"
#include "formats/dbb_run.hpp"
#include "models/compensation/verification.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::simulators::machine {

// The run carries the commanded circle centre as center_a_mm / center_b_mm metadata (also when it is 0),
// so tools that need machine positions (compensation tables) find it. Its angles are the commanded ones, or
// with AngleSource::encoders the axis encoders' about the commanded centre (as a live session's: the drives'
// positions, one servo lag behind), which the metadata's angle_source says.
enum class AngleSource { commanded, encoders };
formats::DbbRun simulate_dbb_run(const Machine& machine, const DbbCircleSpec& spec,
                                 const std::string& source = "simulated", AngleSource angles = AngleSource::commanded);

// The run less its samples from start_s to start_s + duration_s (times as in the run): a dropout, as a
// recording loses it. Throws formats::DbbRunFormatError when what is left is not a run (validate_dbb_run).
formats::DbbRun with_dropout(const formats::DbbRun& run, double start_s, double duration_s);

// The circle test a run file describes (radius, height, direction, feed, plane, start angle), about
// `center` (machine coordinates, m), so the same test can be traced again on the virtual machine.
DbbCircleSpec circle_spec_of(const formats::DbbRun& run, const Vec3& center);

// A LinuxCNC COMP_FILE_TYPE = 0 table (mm) as the controller's compensation of one joint.
JointCompensation joint_compensation(const std::vector<formats::CompTriplet>& table);

// A straightness.csv table (mm) as the controller's cross-axis corrections, one per moving axis.
// Throws std::invalid_argument for an axis other than x, y, z.
std::vector<CrossCompensation> cross_compensation(const std::vector<formats::CrossCorrectionRow>& rows);

// Each run's test traced again on the machine, without (`before`) and with the controller's
// corrections (`after`), about `center`; the runs' `seed` metadata is reused, so runs simulated from
// the same machine file are reproduced exactly in `before`, and their angle_source (a live session's
// angles are the encoders').
struct RemeasuredRuns {
  std::vector<formats::DbbRun> before, after;
};
RemeasuredRuns remeasure_dbb(const MachineConfig& machine, const ControllerCorrection& correction,
                             const std::vector<formats::DbbRun>& runs, const Vec3& center);
// The `after` half alone: each run traced with the corrections, named TAG_<k>_<direction> and with
// `compensation = TAG` metadata.
std::vector<formats::DbbRun> retrace_dbb(const MachineConfig& machine, const ControllerCorrection& correction,
                                         const std::vector<formats::DbbRun>& runs, const Vec3& center,
                                         const std::string& tag);

// The machine as the compensation's verification retraces on (models/compensation/verification.hpp): each
// correction read back from its file (x.comp, straightness.csv) once, as the controller would, or the skew
// entered; the runs traced about the circle centre with a set loaded.
models::compensation::Retrace dbb_retrace(const MachineConfig& machine, const std::vector<formats::DbbRun>& runs);

}  // namespace guideway::simulators::machine
