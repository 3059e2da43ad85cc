// `guideway identify artifact`: six error motions of a linear axis from a 1-D artifact measured on
// a reference (calibration) and by the machine, horizontal and vertical (models/artifact, Wei 2019).
#include <iomanip>
#include <iostream>
#include <memory>
#include <numbers>
#include <sstream>

#include "cli/commands.hpp"
#include "core/csv_table.hpp"
#include "models/artifact/artifact.hpp"
#include "models/artifact/artifact_json.hpp"
#include "core/units.hpp"

namespace guideway::cli {

namespace {

struct ArtifactArgs {
  std::string cal, hor, ver, k_scan, m_scan;
  bool json = false;
  bool no_coupling = false;
  void add(CLI::App& cmd) {
    cmd.add_option("--calibration", cal, "the artifact on the reference (docs/formats.md, 1-D artifact)")->required();
    cmd.add_option("--horizontal", hor, "the artifact measured by the machine, lying horizontally")->required();
    cmd.add_option("--vertical", ver, "the artifact measured by the machine, standing vertically")->required();
    cmd.add_option("--k-scan", k_scan, "displacement scan across one paraboloid (X_M_mm,x_M_px): k from a line fit");
    cmd.add_option("--m-scan", m_scan, "angle scan of one mirror (theta_arcsec,x_F_px): m from a line fit");
    cmd.add_flag("--no-angle-coupling", no_coupling, "leave out Wei's k m epsilon correction (to see its size)");
    cmd.add_flag("--json", json, "print the result as one JSON object");
  }
};

constexpr double arcsec = rad_per_arcsec;

// The optics' constants k and m, and where they came from.
void print_optics(const models::artifact::ArtifactResult& r, bool coupling) {
  std::cout << std::fixed << std::setprecision(4) << "k = " << r.k_m_per_px * 1e6
            << " um/px, m = " << r.m_px_per_rad * arcsec << " px/arcsec, k m = " << r.coupling_m_per_rad * 1e6 * arcsec
            << " um/arcsec" << (coupling ? "" : " (coupling correction OFF)") << "\n";
  if (r.k_scan)
    std::cout << "k from " << r.k_scan->source << ": " << r.k_m_per_px * 1e6 << " um/px (u " << std::setprecision(6)
              << r.u_k_m_per_px * 1e6 << std::setprecision(4) << "), " << r.k_scan->points << " points, residual rms "
              << r.k_scan->residual_rms_px << " px\n";
  if (r.m_scan)
    std::cout << "m from " << r.m_scan->source << ": " << r.m_px_per_rad * arcsec << " px/arcsec (u "
              << std::setprecision(6) << r.u_m_px_per_rad * arcsec << std::setprecision(4) << "), " << r.m_scan->points
              << " points, residual rms " << r.m_scan->residual_rms_px << " px\n";
}

// The six error motions per target in machine directions, value +/- u.
void print_error_motions(const models::artifact::ArtifactResult& r) {
  const char a = static_cast<char>('x' + r.axis);
  std::cout << "error motions of the tool relative to target 0, along " << static_cast<char>('X' + r.axis)
            << " (value +/- standard uncertainty):\n"
            << "target     " << a << "_mm        dx_um         dy_um         dz_um        ex_arcsec     ey_arcsec     "
               "ez_arcsec\n";
  std::cout << std::setprecision(3);
  const auto pm = [](double value, double u) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(3) << std::setw(6) << value << "+/-" << std::setprecision(3) << u;
    return s.str();
  };
  for (const auto& e : r.targets) {
    const auto m = models::artifact::machine_errors(e, r.axis);
    std::cout << std::setw(6) << e.target << std::setw(9) << std::setprecision(2) << e.x_m * 1e3 << "  ";
    for (std::size_t k = 0; k < 3; ++k) std::cout << std::setw(13) << pm(m.d[k] * 1e6, m.u_d[k] * 1e6) << " ";
    for (std::size_t k = 0; k < 3; ++k)
      std::cout << std::setw(13) << pm(m.r[k] / arcsec, m.u_r[k] / arcsec) << (k < 2 ? " " : "\n");
  }
}

void run_artifact(const ArtifactArgs& a, CliContext& /*ctx*/) {
  try {
    const auto c = models::artifact::read_artifact_readings(a.cal, models::artifact::ArtifactPlacement::calibration);
    const auto h = models::artifact::read_artifact_readings(a.hor, models::artifact::ArtifactPlacement::horizontal);
    const auto v = models::artifact::read_artifact_readings(a.ver, models::artifact::ArtifactPlacement::vertical);
    models::artifact::ArtifactOptions opt;
    opt.angle_coupling = !a.no_coupling;
    if (!a.k_scan.empty()) opt.k_scan = models::artifact::read_k_scan(a.k_scan);
    if (!a.m_scan.empty()) opt.m_scan = models::artifact::read_m_scan(a.m_scan);
    const auto r = models::artifact::identify_artifact(c, h, v, opt);
    if (a.json) {
      std::cout << models::artifact::to_json(r).dump() << "\n";
      return;
    }
    print_optics(r, opt.angle_coupling);
    print_error_motions(r);
  } catch (const CsvError& e) {
    throw std::runtime_error(e.what());
  }
}

void add_artifact_commands(CLI::App& app, CliContext& ctx) {
  add_commands(
      *identify_command(app), ctx,
      {command("artifact", "six error motions of a linear axis from a 1-D artifact (Wei 2019)", &run_artifact)});
}

const CommandGroup group(&add_artifact_commands);

}  // namespace

}  // namespace guideway::cli
