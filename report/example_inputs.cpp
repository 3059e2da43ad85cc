// guideway-report-examples OUTDIR [--machine FILE]: writes the example inputs of the report's tests and
// documentation from the virtual machine tool, set up as Mu 2012's vertical lathe (Sec. 4): a machine whose
// only errors are the X carriage's vertical straightness of Mu's Eq. 17 (with guideway bending, so the
// autocollimator sees its slope) and the spindle and noise of config/machine-example.toml (spindle tilt
// 2.8 urad = Mu's squareness, face wobble 0.3 urad, plate parallelism 2.5 urad). --machine FILE uses that
// machine as it is instead.
//   straightness_x.csv  autocollimator traverse of X, 0..600 mm, reflector feet 10 mm apart
//   runout.csv          one revolution of the micrometer at the rim of a 1000 mm thrust plate (Fig. 10)
//   profile.csv         the faced profile, 600 mm at 2 mm/min and 110 rpm, every 0.5 mm
// DBB runs come from `guideway simulate dbb`, the Union Jack set from the Moody 1955 data.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <string>

#include "drivers/profilometer/profile_files.hpp"
#include "simulators/machine/machine.hpp"

namespace {

constexpr double kArcsecPerRad = 180.0 * 3600.0 / std::numbers::pi;

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f.flush()) throw std::runtime_error(path.string() + ": cannot write");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace guideway;
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::cerr << "usage: guideway-report-examples OUTDIR [--machine FILE]\n";
    return argc < 2 ? 2 : 0;
  }
  try {
    const std::filesystem::path out = argv[1];
    std::filesystem::create_directories(out);
    sim::MachineConfig cfg;
    if (argc >= 4 && std::string(argv[2]) == "--machine") {
      cfg = sim::load_machine_config(argv[3]);
    } else {
      const auto example = sim::default_machine_config();
      cfg.name = "mu2012-lathe (Eq. 17 on " + example.name + ")";
      cfg.spindle = example.spindle;
      cfg.noise = example.noise;
      // Mu's Eq. 17: E_z(x) in mm for x in mm, coefficients of x^0..x^5; in SI: c_k * 1e-3 * 1e3^k.
      const double eq17[] = {2.41e-4, -5.19e-7, 2.29e-8, -1.558e-10, 3.4e-13, -2.3e-16};
      auto& x_axis = cfg.axis[static_cast<int>(sim::Axis::x)];
      for (int k = 0; k < 6; ++k) x_axis.translation[2].c.push_back(eq17[k] * 1e-3 * std::pow(1e3, k));
      x_axis.bending = true;
    }
    const sim::Machine machine(cfg);

    // Autocollimator along X, reflector feet 10 mm apart; rear-foot positions 0..590 mm.
    sim::TraverseSpec ts;
    ts.axis = sim::Axis::x;
    ts.start_m = 0.0;
    ts.end_m = 0.59;
    ts.step_m = 0.01;
    std::string s = "# machine = " + cfg.name + "\n# source = guideway-report-examples (virtual machine tool)\n";
    s += "# step_mm = 10\nx_mm,pitch_arcsec\n";
    for (const auto& st : machine.autocollimator_traverse(ts))
      s += num(st.position_m * 1e3) + "," + num(-st.pitch_rad * kArcsecPerRad) + "\n";
    write_file(out / "straightness_x.csv", s);

    // Micrometer at the rim of a 1000 mm plate, one revolution (Mu 2012, Fig. 10).
    sim::RunoutSpec rs;
    rs.probe_radius_m = 0.5;
    rs.samples_per_rev = 360;
    const double parallelism_um = cfg.spindle.plate_parallelism_rad * 2 * rs.probe_radius_m * 1e6;
    std::string r = "# machine = " + cfg.name + "\n# source = guideway-report-examples (virtual machine tool)\n";
    r += "# plate_diameter_mm = " + num(2 * rs.probe_radius_m * 1e3) + "\n# parallelism_um = " + num(parallelism_um) +
         "\n# travel_mm = 600\nangle_deg,runout_um\n";
    for (const auto& p : machine.runout_revolution(rs))
      r += num(p.angle_rad * 180 / std::numbers::pi) + "," + num(p.displacement_m * 1e6) + "\n";
    write_file(out / "runout.csv", r);

    // Facing cut as in Mu's experiment: 600 mm traverse at 2 mm/min, 110 rpm, profile every 0.5 mm.
    sim::FacingSpec fs;
    fs.spindle_rpm = 110;
    fs.profile_step_m = 0.0005;
    profilometer::Profile prof;
    for (const auto& p : machine.facing_profile(fs)) {
      prof.x_m.push_back(p.x_m);
      prof.z_m.push_back(p.z_m);
    }
    prof.metadata = {{"machine", cfg.name},
                     {"source", "guideway-report-examples (virtual machine tool)"},
                     {"feed_mm_per_min", num(fs.feed_m_per_s * 60000)},
                     {"spindle_rpm", num(fs.spindle_rpm)}};
    profilometer::write_profile_csv((out / "profile.csv").string(), prof);
    std::cout << "wrote straightness_x.csv runout.csv profile.csv to " << out.string() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "guideway-report-examples: " << e.what() << "\n";
    return 1;
  }
}
