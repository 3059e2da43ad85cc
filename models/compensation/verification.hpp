#pragma once
// The verification of a compensation (docs/compensation.md, "--verify"): the same test traced again on a
// virtual machine without and with the files written (read back from them, as a controller would), each
// run's circular deviation G, what is still left, and which files (and the skew) are not fit to load
// because with them some run's G grows; for a test in several planes, the planes together. The virtual
// machine is handed in (Retrace; simulators/machine's dbb_retrace), so the logic stays here and
// `guideway compensate` only parses and prints. Pure but for the files it reads and writes; thread safe.

#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "formats/dbb_run.hpp"
#include "models/compensation/compensation.hpp"
#include "models/dbb/identify.hpp"
#include "models/explain/dbb_checked.hpp"

namespace guideway::models::compensation {

// One correction the user is told to load (a file) or enter (the skew).
struct Correction {
  enum class Kind { table, skew, cross };
  std::string file;  // "x.comp", "axis skew", "straightness.csv"
  Kind kind = Kind::table;
  std::string path;   // table, cross: the file as written, read back as the controller would
  int joint = 0;      // table: 0 x, 1 y, 2 z
  std::string plane;  // skew: its plane
  double skew_rad = 0.0;
};

// The virtual machine that traces the test again about the circle centre `center_m` (x, y, z), on the
// sample grid of the measured runs, reusing each run's noise: as it is and with every correction of a set
// loaded (one trace for both), and with a set alone (as the `after` half).
struct Retrace {
  using Set = std::vector<const Correction*>;
  using Runs = std::vector<formats::DbbRun>;
  std::function<std::pair<Runs, Runs>(const Set& all, const std::array<double, 3>& center_m)> before_and_after;
  std::function<Runs(const Set& set, const std::array<double, 3>& center_m)> with;
};

// A file (or the skew) not to load, and why.
struct Refusal {
  std::string file;
  std::string why;
};

struct Verification {
  // The retraced runs, identified as the compensation was (what EXPLAIN finds fitted beside).
  dbb::Identification before, after;
  // Each run's G: before; with the tables; + the squareness as axis skew; + straightness.csv as the
  // cross-axis correction (`after`: everything the files and the advice correct). Of the readings less what
  // was fitted beside on the retraced runs before (a drift, a vibration: no table holds it, and it would
  // judge the tables by what they are not for); as measured in g_*_measured.
  std::vector<double> g_before, g_tables, g_skewed, g_after;
  std::vector<double> g_before_measured, g_after_measured;
  std::vector<std::string> beside;  // what was taken out of G (the effects)
  bool skew = false;                // the squareness was applied and entered as the controller's axis skew
  bool cross = false;               // straightness.csv was written and loaded
  std::vector<Refusal> refused;     // the files (and the skew) not to load
  // What is fit to load and each run's G with it (less what was fitted beside, and as measured).
  std::vector<std::string> loadable;
  std::vector<double> g_loadable, g_loadable_measured;
  std::vector<formats::DbbRun> runs_before, runs_after;  // the retraces, for write_verify_runs
  std::vector<std::string> written;                      // where write_verify_runs put them
  // What was traced, to trace a set of it again (together): every correction, the circle centre and what
  // G is taken less.
  std::vector<Correction> corrections;
  std::array<double, 3> center_m{};
  std::vector<double> less_um;
};

// Each run's circular deviation G (ISO 230-4: the range of its reading about its least-squares circle), um,
// of the reading less `less_um` (one value per sample of all the runs; empty or of another size: nothing).
std::vector<double> g_of_runs(const std::vector<formats::DbbRun>& runs, const std::vector<double>& less_um = {});

// Traces every run's test on the virtual machine: as it is, with the tables of `axes` written to `out_dir`,
// then adding the squareness as the axis-skew correction the user is told to enter, then the cross-axis
// correction of straightness.csv (when written); refuses what makes a run worse.
Verification verify(const std::vector<formats::DbbRun>& runs, const explain::CheckedIdentification& checked,
                    const ErrorMap& map, const std::string& out_dir, const std::vector<std::string>& axes,
                    const Retrace& retrace);

// Writes the retraced runs (before_*.csv, after_*.csv) to `dir`, first removing those of an earlier check
// (which would otherwise join this one's in a report of the directory); records the paths in `v.written`.
void write_verify_runs(Verification& v, const std::filesystem::path& dir);

// The verifications of the planes as one: every plane's refusals (a file refused in one plane is not loaded
// in any), their runs' G in the planes' order. G with what is fit to load is each plane's own; it is left
// out when a plane's loadable set is not the union's (it was not traced with the union's set).
Verification merged(const std::vector<ErrorMap>& maps, const std::vector<Verification>& vs);

// The planes' verifications made one set to load: a file refused in one plane is loaded in none, so a plane
// left with less than its own fit set (y.comp without the x.comp the xz plane refused) is traced again with
// what the union leaves it and, while a run of it grows, refuses more by the same rule, until no plane's
// run is larger than before with the union's set. Each plane's loadable set and G are then the union's
// (`vs` updated; `retraces[i]` traces plane i); returns merged(maps, vs).
Verification together(const std::vector<ErrorMap>& maps, std::vector<Verification>& vs,
                      const std::vector<Retrace>& retraces);

// The refusal rule over a set: while with `set` loaded some run's G (`g`) is larger than `g_before`
// (beyond 0.5 nm, the printed resolution), the correction whose removal leaves the smallest worst growth is
// refused, naming the run it made worse (by `run_label`). `g_of(set)` is G with a set loaded. On return
// `set` and `g` are what is left and its G.
std::vector<Refusal> refuse_growth(
    const std::vector<double>& g_before, std::vector<const Correction*>& set, std::vector<double>& g,
    const std::function<std::vector<double>(const std::vector<const Correction*>&)>& g_of,
    const std::function<std::string(std::size_t)>& run_label);

bool refused(const std::vector<Refusal>& list, const std::string& file);

// The refused files renamed NAME.do-not-load (a file named x.comp invites loading it) and linuxcnc.ini
// rewritten for the tables that remain, as one set (core/atomic_file: the earlier files whole, or the new
// ones). Returns each refusal with the name it was renamed to ("" for the skew or a file not there).
struct AppliedRefusal {
  std::string file, why, renamed_to;
};
std::vector<AppliedRefusal> apply_refusals(const Verification& v, const std::string& out_dir,
                                           const std::vector<std::string>& axes, const std::string& source);

}  // namespace guideway::models::compensation
