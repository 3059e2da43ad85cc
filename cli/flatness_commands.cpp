// `guideway identify straightness|unionjack|runout|flatness`: offline evaluation of an autocollimator
// traverse, a Union Jack surface-plate set, a spindle run-out revolution and the profiles of a faced
// workpiece (models/flatness).
#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <vector>

#include "cli/commands.hpp"
#include "cli/instrument_options.hpp"
#include "core/csv_table.hpp"
#include "core/number_format.hpp"
#include "models/flatness/instruments.hpp"
#include "models/flatness/json.hpp"
#include "models/flatness/runout.hpp"
#include "models/flatness/straightness.hpp"
#include "models/flatness/union_jack.hpp"
#include "models/flatness/workpiece_flatness.hpp"
#include "models/flatness/workpiece_flatness_json.hpp"
#include "results/parameters.hpp"

namespace guideway::cli {

namespace {

template <class F>
void run_reporting(F&& f) {
  try {
    f();
  } catch (const CsvError& e) {
    throw std::runtime_error(e.what());
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
}

// Five significant digits, the u's two: a deflectometer's are nanometres, a TA80's tenths of a micrometre.
void print_line(const char* name, const models::flatness::ReferenceLine& r, bool data_u) {
  const auto um = [](double m) { return significant_digits(m * 1e6, 2); };
  std::cout << "  " << std::left << std::setw(15) << name << std::right << std::setw(9)
            << significant_digits(r.straightness_m * 1e6, 5) << " um  (u " << um(r.u_straightness_m)
            << " um: first order " << um(r.u_first_order_m) << ", selection bias " << um(r.selection_bias_m);
  if (data_u && std::isfinite(r.u_straightness_data_m))
    std::cout << "; from the readings' scatter u " << um(r.u_straightness_data_m) << " um";
  std::cout << "), max at station " << r.max_index << ", min at " << r.min_index << "\n";
}

void print_profile(const models::flatness::StraightnessProfile& p) {
  constexpr double as = 1 / models::flatness::rad_per_arcsec;
  std::cout << p.plane << " straightness (u per reading " << std::setprecision(3) << p.u_angle_rad * as
            << " arcsec, u at the end of the integration " << p.u_height_m.back() * 1e6 << " um):\n";
  std::cout << "  readings: middle " << significant_digits(p.tilt_rad * as, 6) << " arcsec (a tilt), span "
            << significant_digits(p.span_rad * as, 6) << " arcsec";
  if (std::isfinite(p.u_angle_data_rad))
    std::cout << ", scatter " << significant_digits(p.u_angle_data_rad * as, 3) << " arcsec (finest wavelet details)";
  std::cout << "\n";
  if (!p.u_disagreement.empty()) std::cout << "  note: " << p.u_disagreement << "\n";
  const bool data_u = !p.u_disagreement.empty();
  print_line("end-point line", p.end_point, data_u);
  print_line("least squares", p.least_squares, data_u);
  print_line("minimum zone", p.minimum_zone, data_u);
  const auto& f = p.polynomial;
  std::cout << "  polynomial (Mu Eq. 10, x in mm from the first station, height in mm), order " << f.order << " by BIC"
            << (f.order > 1 && f.order == static_cast<int>(f.bic.size())
                    ? " (the highest tried, --max-order: the surface is not a polynomial of a low order; the values "
                      "above do not use it)"
                    : "")
            << ":\n    Ez =";
  std::cout << std::scientific << std::setprecision(4);
  for (std::size_t k = f.b.size(); k-- > 0;) {
    const double b_mm = f.b[k] * 1e3 / std::pow(1e3, static_cast<double>(k));
    std::cout << (b_mm < 0 ? " - " : " + ") << std::abs(b_mm);
    if (k > 0) std::cout << " x" << (k > 1 ? "^" + std::to_string(k) : "");
  }
  std::cout << std::fixed << std::setprecision(4) << "\n    fit residual rms " << f.residual_rms_m * 1e6 << " um, max "
            << f.residual_max_m * 1e6 << " um; angle residual rms "
            << f.angle_residual_rms_rad / models::flatness::rad_per_arcsec << " arcsec\n";
  std::cout << "  " << std::setw(9) << "x_mm" << std::setw(12) << "height_um" << std::setw(10) << "u_um"
            << std::setw(12) << "endpt_um" << std::setw(12) << "lsq_um"
            << "\n";
  for (std::size_t k = 0; k < p.x_m.size(); ++k)
    std::cout << "  " << std::setw(9) << std::setprecision(2) << p.x_m[k] * 1e3 << std::setprecision(4) << std::setw(12)
              << p.height_m[k] * 1e6 << std::setw(10) << p.u_height_m[k] * 1e6 << std::setw(12)
              << p.end_point.deviation_m[k] * 1e6 << std::setw(12) << p.least_squares.deviation_m[k] * 1e6 << "\n";
}

struct StraightnessOptions {
  std::string file;
  bool json = false;
  InstrumentOptions instrument;
  int max_order = 8;
  void add(CLI::App& cmd) {
    cmd.add_option("ANGLES.csv", file,
                   "traverse file (docs/formats.md, Straightness traverse), or a DABAM entry (NAME.dat with "
                   "NAME.txt beside it)")
        ->required();
    cmd.add_flag("--json", json, "print the result as one JSON object");
    instrument.add(cmd);
    cmd.add_option("--max-order", max_order, "highest polynomial order tried by the BIC selection")
        ->check(CLI::Range(1, 12));
  }
};

void run_straightness(const StraightnessOptions& o, CliContext& /*ctx*/) {
  run_reporting([&] {
    models::flatness::StraightnessOptions opt;
    opt.instrument = o.instrument.of(o.file);
    opt.max_order = o.max_order;
    const auto tr = models::flatness::read_angle_traverse(o.file, opt.instrument);
    const auto r = models::flatness::identify_straightness(tr, opt);
    if (o.json) {
      std::cout << models::flatness::to_json(r).dump() << "\n";
      return;
    }
    std::cout << r.source << ": " << r.readings << " readings, step " << r.step_m * 1e3 << " mm";
    if (r.jitter > 0)
      std::cout << " (positions jitter by up to " << significant_digits(100 * r.jitter, 2)
                << " % of it: each reading's own spacing used; tolerance "
                << significant_digits(100 * models::flatness::station_jitter_tolerance, 2) << " %)";
    std::cout << "\ninstrument: " << r.instrument.name << ", range +-"
              << significant_digits(r.instrument.range_rad / models::flatness::rad_per_arcsec, 6)
              << " arcsec about the readings' middle\n";
    print_profile(r.vertical);
    if (r.horizontal) print_profile(*r.horizontal);
  });
}

struct UnionJackOptions {
  std::string dir;
  bool json = false;
  bool lsq = false;
  double foot_mm = 0.0;
  void add(CLI::App& cmd) {
    cmd.add_option("DIR", dir, "directory with NW_SE.txt ... N_S.txt and Config.txt")->required();
    cmd.add_flag("--json", json, "print the result as one JSON object");
    cmd.add_flag("--least-squares", lsq, "also evaluate all eight lines together by least squares");
    cmd.add_option("--foot-spacing-mm", foot_mm, "reflector foot spacing (overrides Config.txt), (0, 1000] mm")
        ->check(CLI::Range(1e-6, 1000.0));
  }
};

// The Union Jack result in `unit` (um, or 10 uin for a set in inches): flatness, closures, each line's heights.
void print_union_jack(const std::string& dir, const models::flatness::UnionJackResult& r, bool inch) {
  const double unit = inch ? 0.0254e-5 : 1e-6;
  const char* uname = inch ? "x10 uin" : "um";
  std::cout << dir << ": foot spacing " << std::setprecision(4) << r.foot_spacing_m * 1e3 << " mm, " << r.long_steps
            << " x " << r.short_steps << " steps, diagonals " << r.diagonal_steps << "\n";
  for (const auto& w : r.warnings) std::cout << "warning: " << w << "\n";
  std::cout << std::fixed << std::setprecision(3);
  std::cout << "flatness (Moody datum): " << r.flatness_m * 1e6 << " um";
  if (inch) std::cout << " = " << r.flatness_m / unit << " " << uname;
  std::cout << "\nflatness about the least-squares plane of the Moody heights: " << r.flatness_lsq_plane_m * 1e6
            << " um\nflatness (minimum zone of the Moody heights): " << r.flatness_min_zone_m * 1e6 << " um\n";
  for (const auto& l : r.lines)
    if (l.closure_m)
      std::cout << "closure of " << l.name << ": " << *l.closure_m * 1e6 << " um = " << *l.closure_m / unit << " "
                << uname << "\n";
  for (const auto& l : r.lines) {
    std::cout << l.name << " (x, y in station units; height " << uname << "):";
    for (std::size_t k = 0; k < l.stations.size(); ++k)
      std::cout << (k % 6 == 0 ? "\n  " : "  ") << std::setprecision(2) << "(" << l.stations[k].x_steps << ","
                << l.stations[k].y_steps << ") " << std::setprecision(3) << l.stations[k].height_m / unit;
    std::cout << "\n";
  }
  if (r.lsq)
    std::cout << "least squares (all lines, one angular offset per line): flatness about the plane "
              << r.lsq->flatness_m * 1e6 << " um, minimum zone " << r.lsq->flatness_min_zone_m * 1e6
              << " um, residual rms " << r.lsq->residual_rms_rad / models::flatness::rad_per_arcsec
              << " arcsec, redundancy " << r.lsq->redundancy << "\n";
}

void run_union_jack(const UnionJackOptions& o, CliContext& /*ctx*/) {
  run_reporting([&] {
    const auto set = models::flatness::read_union_jack(o.dir, o.foot_mm * 1e-3);
    models::flatness::UnionJackOptions opt;
    opt.least_squares = o.lsq;
    const auto r = models::flatness::evaluate_union_jack(set, opt);
    const bool inch = set.inch_units && !(o.foot_mm > 0);
    if (o.json) {
      std::cout << models::flatness::to_json(r, inch).dump() << "\n";
      return;
    }
    print_union_jack(o.dir, r, inch);
  });
}

struct RunoutOptions {
  std::string file;
  std::string turned;
  bool json = false;
  void add(CLI::App& cmd) {
    cmd.add_option("RUNOUT.csv", file, "revolution file (angle_deg,runout_um; docs/formats.md)")->required();
    cmd.add_option("TURNED.csv", turned,
                   "a second record with the artifact turned (its artifact_turned_deg; both with angles from the "
                   "spindle's zero): the spindle's synchronous error motion with the artifact's form removed "
                   "(Donaldson's reversal)");
    cmd.add_flag("--json", json, "print the result as one JSON object");
  }
};

// The reversal's figures after the first record's.
void print_reversal(const nlohmann::json& rv) {
  std::cout << "reversal (Donaldson) with " << rv["records"][1].get<std::string>() << ", the artifact turned "
            << std::setprecision(1) << rv["turned_deg"].get<double>() << " deg:\n";
  for (const results::Parameter* p : {&results::spindle_synchronous_error_motion, &results::artifact_form_error}) {
    const auto shown = results::shown(results::name(*p), rv[results::name(*p)].get<double>(),
                                      std::numeric_limits<double>::quiet_NaN());
    std::cout << "  " << shown.label << " = " << shown.value << " " << shown.unit << "\n";
  }
  if (!rv["together_orders"].empty()) {
    // A long list (at 180 deg every even order) as its first three and its last.
    const auto& list = rv["together_orders"];
    std::string orders;
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (list.size() > 6 && i == 3) orders += ", ...";
      if (list.size() > 6 && i >= 3 && i + 1 < list.size()) continue;
      orders += (orders.empty() ? "" : ", ") + std::to_string(list[i].get<int>());
    }
    std::cout << "  orders " << orders
              << " stay in the spindle's figure with the form (the turn leaves them in place)\n";
  }
}

// ISO 230-7's figures of a record, and a reversal's when two records were given.
void print_error_motion(const nlohmann::json& j) {
  if (!j.contains("error_motion")) {
    std::cout << "error motion (ISO 230-7): less than one whole revolution recorded\n";
    return;
  }
  const nlohmann::json& em = j["error_motion"];
  const auto revolutions = em["revolutions"].get<std::size_t>();
  std::cout << "error motion (ISO 230-7) over " << revolutions << (revolutions == 1 ? " revolution" : " revolutions")
            << ", the once-per-revolution term (" << std::setprecision(4)
            << em[results::name(results::fundamental_error_motion)].get<double>() << " um) removed:\n";
  for (const results::Parameter* p :
       {&results::total_error_motion, &results::synchronous_error_motion, &results::asynchronous_error_motion}) {
    const auto shown = results::shown(results::name(*p), em[results::name(*p)].get<double>(),
                                      std::numeric_limits<double>::quiet_NaN());
    std::cout << "  " << shown.label << " = " << shown.value << " " << shown.unit << "\n";
  }
  if (j.contains("reversal")) print_reversal(j["reversal"]);
}

void run_runout(const RunoutOptions& o, CliContext& /*ctx*/) {
  run_reporting([&] {
    const auto rev = models::flatness::read_runout_revolution(o.file);
    const auto r = models::flatness::identify_runout(rev);
    nlohmann::json j = models::flatness::runout_json(rev);
    if (!o.turned.empty())
      j["reversal"] = models::flatness::reversal_json(rev, models::flatness::read_runout_revolution(o.turned));
    if (o.json) {
      std::cout << j.dump() << "\n";
      return;
    }
    std::cout << std::fixed << std::setprecision(4);
    std::cout << o.file << ": " << r.samples << " samples\n"
              << "once per revolution: amplitude " << r.amplitude_m * 1e6 << " um (u " << r.u_amplitude_m * 1e6
              << "), maximum at " << std::setprecision(2) << r.phase_rad * 180 / std::numbers::pi << " deg (u "
              << r.u_phase_rad * 180 / std::numbers::pi << ")\n"
              << std::setprecision(4) << "run-out r = 2A = " << r.runout_m * 1e6 << " um (u " << r.u_runout_m * 1e6
              << "), parallelism p = " << r.parallelism_m * 1e6 << " um, plate diameter L = " << std::setprecision(1)
              << r.plate_diameter_m * 1e3 << " mm\n"
              << "deflection angle = squareness (r + p) / L = " << std::setprecision(3) << r.deflection_rad * 1e6
              << " urad (u " << r.u_deflection_rad * 1e6 << ")\n";
    if (r.travel_m)
      std::cout << "squareness amplitude over " << std::setprecision(1) << *r.travel_m * 1e3
                << " mm travel: " << std::setprecision(3) << *r.squareness_amplitude_m * 1e6 << " um (u "
                << *r.u_squareness_amplitude_m * 1e6 << ")\n";
    print_error_motion(j);
  });
}

struct WorkpieceOptions {
  std::vector<std::string> profiles;
  std::string straightness;
  std::string runout;
  bool json = false;
  std::string wavelet = "db1";
  int levels = 5;
  InstrumentOptions instrument;
  void add(CLI::App& cmd) {
    cmd.add_option("--profile", profiles, "faced-workpiece profile, x_mm,z_um (repeatable; docs/formats.md)")
        ->required();
    cmd.add_option("--straightness", straightness, "autocollimator traverse of the X carriage (x_mm,pitch_arcsec)")
        ->required();
    cmd.add_option("--runout", runout, "run-out revolution for the Eq. 21 cross-check (angle_deg,runout_um)");
    cmd.add_option("--wavelet", wavelet, "Daubechies wavelet of the decomposition (Mu: db1)");
    cmd.add_option("--levels", levels, "decomposition levels; s1 = the approximation at the deepest")
        ->check(CLI::Range(1, 20));
    instrument.add(cmd);
    cmd.add_flag("--json", json, "print the result as one JSON object");
  }
};

// Per profile: its size and cut, the correlations before and after the wavelet step, the dominant
// error and the squareness it gives.
void print_profile_flatness(const models::flatness::ProfileFlatness& p) {
  std::cout << p.source << ": " << p.points << " points, " << std::setprecision(1) << p.x_start_m * 1e3 << ".."
            << p.x_end_m * 1e3 << " mm, feed " << p.feed_m_per_s * 60e3 << " mm/min, " << p.spindle_rpm << " rpm; p-v "
            << std::setprecision(3) << p.peak_to_valley_m * 1e6 << " um (low frequency "
            << p.low_frequency_peak_to_valley_m * 1e6 << " um)\n";
  for (const auto& c : p.correlations)
    std::cout << "  " << std::left << std::setw(13) << c.name << std::right << " gamma before wavelet (Eq. 19) "
              << std::setw(7) << c.gamma_before << ", after (Eq. 20) " << std::setw(7) << c.gamma_after << "\n";
  std::cout << "  dominant: " << p.dominant << " (impact factor " << p.impact_factor << ")\n"
            << "  squareness " << p.squareness_rad * 1e6 << " urad (u " << p.u_squareness_rad * 1e6 << "), amplitude "
            << p.squareness_amplitude_m * 1e6 << " um (u " << p.u_squareness_amplitude_m * 1e6 << ")\n";
}

void print_workpiece_flatness(const models::flatness::WorkpieceFlatnessResult& r, const std::string& runout) {
  std::cout << std::fixed << std::setprecision(3);
  std::cout << "straightness y2 (Eq. 10, " << r.straightness_source << "): order " << r.straightness.order
            << ", fit residual rms " << r.straightness.residual_rms_m * 1e6 << " um\n"
            << "wavelet " << r.wavelet << ", " << r.levels << " levels; s1 = A" << r.levels << "\n";
  for (const auto& p : r.profiles) print_profile_flatness(p);
  std::cout << "dominant error: " << r.dominant << " (impact factor " << r.impact_factor << ")\n"
            << "squareness (all profiles): " << r.squareness_rad * 1e6 << " urad (u " << r.u_squareness_rad * 1e6
            << "), amplitude over " << std::setprecision(1) << r.travel_m * 1e3 << " mm: " << std::setprecision(3)
            << r.squareness_amplitude_m * 1e6 << " um (u " << r.u_squareness_amplitude_m * 1e6 << ")\n";
  if (r.runout_check) {
    const auto& c = *r.runout_check;
    std::cout << "Eq. 21 from " << runout << ": " << c.runout.deflection_rad * 1e6 << " urad (u "
              << c.runout.u_deflection_rad * 1e6 << "); profile - Eq. 21 = " << c.difference_rad * 1e6 << " urad (u "
              << c.u_difference_rad * 1e6 << "): " << (c.consistent ? "consistent" : "NOT consistent")
              << " within 2u\n";
  }
}

void run_workpiece_flatness(const WorkpieceOptions& o, CliContext& /*ctx*/) {
  run_reporting([&] {
    models::flatness::StraightnessOptions sopt;
    sopt.instrument = o.instrument.of(o.straightness);
    std::vector<models::flatness::WorkpieceProfile> ps;
    for (const auto& f : o.profiles) ps.push_back(models::flatness::read_workpiece_profile(f));
    const auto tr = models::flatness::read_angle_traverse(o.straightness, sopt.instrument);
    std::optional<models::flatness::RunoutRevolution> rev;
    if (!o.runout.empty()) rev = models::flatness::read_runout_revolution(o.runout);
    models::flatness::WorkpieceFlatnessOptions opt;
    opt.wavelet = o.wavelet;
    opt.levels = o.levels;
    const auto r = models::flatness::analyse_workpiece_flatness(ps, tr, rev, opt, sopt);
    if (o.json) {
      std::cout << models::flatness::to_json(r).dump() << "\n";
      return;
    }
    print_workpiece_flatness(r, o.runout);
  });
}

void add_flatness_commands(CLI::App& app, CliContext& ctx) {
  add_commands(
      *identify_command(app), ctx,
      {command("straightness", "straightness from an autocollimator traverse (x_mm,pitch_arcsec[,yaw_arcsec])",
               &run_straightness),
       command("unionjack", "surface-plate flatness by the Union Jack (Moody) method", &run_union_jack),
       command("runout", "squareness from a spindle run-out revolution (Mu Eq. 21)", &run_runout),
       command("flatness", "which carriage error shows on a faced workpiece: wavelet step and correlation (Mu 2012)",
               &run_workpiece_flatness)});
}

const CommandGroup group(&add_flatness_commands);

}  // namespace

}  // namespace guideway::cli
