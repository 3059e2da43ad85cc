#pragma once
// EXPLAIN for spindle run-out records (an inductance micrometer on a face at a radius, several
// revolutions; docs/explain.md "Run-out"). Base: per record an offset and the once-per-revolution
// sinusoid (the face's tilt to the spindle axis, Mu's Eq. 21 term; ISO 230-7 removes it too).
// Candidates: every effect of the library with a run-out term (models/explain/effects/):
// synchronous_harmonic (orders 2..K, the same every revolution: spindle and artifact form together, or the
// spindle's alone beside artifact_form when records with the artifact turned between them share the
// spindle's angle zero: Donaldson's reversal),
// asynchronous_line (a line at a non-integer order: a bearing defect), thermal_drift (the spindle's
// axial growth with time), speed_variation (the spindle's speed off or drifting from the nominal rpm, so
// the readings' angles slip against the time they were taken at), speed_ripple (the speed varying
// periodically, the angles slipping back and forth). Angles come from time and the nominal
// rpm (the micrometer has no spindle angle). Pure functions; thread safe; throw std::invalid_argument.

#include <optional>
#include <string>
#include <vector>

#include "models/explain/explain_result.hpp"

namespace guideway::models::flatness {
struct RunoutRevolution;
}

namespace guideway::models::explain {

struct Problem;  // explain.hpp (the engine, with Eigen): only for who builds or inspects problems

struct RunoutRecord {
  std::string source;
  double rpm = 0.0;
  std::vector<double> angle_rad;  // nominal spindle angle of each reading from the record's start, increasing
  std::vector<double> runout_m;
  // Donaldson's reversal (the file's artifact_turned_deg, angle_zero; models/flatness/runout.hpp): the
  // artifact's turn since the first record, and whether the angles count from the spindle's zero.
  std::optional<double> artifact_turned_rad;
  bool angle_from_spindle_zero = true;
};

// A run-out file (docs/formats.md "Run-out revolution") with its `rpm` metadata (the runout session
// writes it); errors name the file.
RunoutRecord read_runout_record(const std::string& path);
RunoutRecord parse_runout_record(const std::string& text, const std::string& source);
// The same from a parsed revolution and its rpm (e.g. the daemon's runout session).
RunoutRecord runout_record(const flatness::RunoutRevolution& revolution, double rpm);

Problem runout_problem(const std::vector<RunoutRecord>& records);
Report explain_runout(const std::vector<RunoutRecord>& records, const ExplainOptions& options = {});

}  // namespace guideway::models::explain
