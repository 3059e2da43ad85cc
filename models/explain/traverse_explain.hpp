#pragma once
// EXPLAIN for autocollimator straightness traverses (docs/explain.md "Traverses"): passes of the reflector
// along an axis, forward (+) and return (-), each reading the slope angle at its station. What is
// explained: the pitch readings as slopes in um/m (= urad), white noise from reading to reading (the heights
// they integrate to are a random walk, which the tests could not judge). Base: the straightness polynomial
// the identification fits (Mu 2012 Eq. 10 through the chord slopes of Eq. 12, order by BIC on all passes
// together, models/flatness/straightness.hpp), common to every pass -- the geometry forward and return
// share -- plus an offset per file after the first (each set-up zeroes the instrument anew); where the passes
// revisit the stations and share more than that polynomial, a term per station, fitted out of the readings
// (Problem::station_means_absorbed), whatever the number of stations.
// Candidates: every effect of the library with a traverse term (models/explain/effects/): angle_drift
// (the instrument's or the air's zero drifting in time: forward and return disagree by a trend in
// time), reflector_rocking (an angle that flips sign with the direction of travel), pitch_wave (a pitch
// periodic along the axis: rack, lead screw), yaw_coupling (the yaw reading's shape in the pitch). Pure
// functions; thread safe; throw std::invalid_argument (file errors: CsvError "file:line: ...").

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "models/explain/explain_result.hpp"
#include "models/flatness/angles.hpp"

namespace guideway::models::flatness {
struct AngleTraverse;  // straightness.hpp
}

namespace guideway::models::explain {

struct Problem;  // explain.hpp (the engine, with Eigen): only for who builds or inspects problems

// One pass of the reflector: its readings in the order taken.
struct TraversePass {
  std::string source;             // file (and pass) it comes from, for the locations reported
  std::size_t file = 0;           // index of the file (set-up) it comes from: passes of one file share a clock
  int direction = 1;              // +1: x increases from reading to reading; -1: the return
  double step_m = 0.0;            // foot spacing = station pitch
  std::vector<double> x_m;        // rear foot of each reading (docs/formats.md)
  std::vector<double> t_s;        // time of each reading on the file's clock; empty: not recorded
  std::vector<double> pitch_rad;  // > 0 rising towards +x
  std::vector<double> yaw_rad;    // empty: not measured
};

// A traverse file (docs/formats.md "Straightness traverse", with its optional `t_s` and `pass` columns):
// its passes, in file order. Rows of a pass are contiguous and one step apart in one direction; without
// a `pass` column the file is one pass. Throws CsvError naming the file and line.
// Positions one step apart within flatness::station_jitter_tolerance; angles within the instrument's range
// about the file's middle (flatness::check_instrument_range).
std::vector<TraversePass> parse_traverse_passes(const std::string& text, const std::string& source,
                                                std::size_t file = 0, const flatness::Autocollimator& ac = {});
// A traverse file, or a DABAM slope profile (NAME.dat or NAME.txt: one forward pass without times, read as
// flatness::read_angle_traverse reads it).
std::vector<TraversePass> read_traverse_passes(const std::string& path, std::size_t file = 0,
                                               const flatness::Autocollimator& ac = {});
// The passes of several files, each file its own index, each read with instrument_of(path) (default:
// flatness::default_instrument, the deflectometer for a DABAM entry, the autocollimator otherwise).
std::vector<TraversePass> read_traverse_files(
    const std::vector<std::string>& paths,
    const std::function<flatness::Autocollimator(const std::string&)>& instrument_of = {});
// A slope profile read as a traverse (flatness::slope_profile_traverse) as one forward pass, no times.
TraversePass slope_profile_pass(const flatness::AngleTraverse& traverse, std::size_t file = 0);

Problem traverse_problem(const std::vector<TraversePass>& passes);
Report explain_traverses(const std::vector<TraversePass>& passes, const ExplainOptions& options = {});

}  // namespace guideway::models::explain
