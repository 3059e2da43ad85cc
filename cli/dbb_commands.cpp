// `guideway identify dbb` and `guideway simulate dbb`: offline DBB identification (Lai's third-order
// model and ballbar diagnostics) and DBB runs from the virtual machine tool.
#include <cmath>
#include <iostream>
#include <memory>
#include <numbers>

#include "cli/commands.hpp"
#include "core/toml_access.hpp"
#include "models/dbb/json.hpp"
#include "simulators/machine/dbb_runs.hpp"

namespace guideway::cli {

namespace {

void add_dbb_commands(CLI::App& app, CliContext& /*ctx*/) {
  auto* identify = identify_command(app);
  auto* id = identify->add_subcommand("dbb", "DBB circular tests: Lai third-order model and ballbar diagnostics");
  struct IdOpts {
    std::vector<std::string> files;
    bool json = false;
    double period_a_mm = 0, period_b_mm = 0;
    bool per_run_center = false;
  };
  auto io = std::make_shared<IdOpts>();
  id->add_option("runs", io->files, "DBB run files (guideway/dbb-run/1 CSV)")->required()->check(CLI::ExistingFile);
  id->add_flag("--json", io->json, "print the result as one JSON object");
  id->add_option("--cyclic-period-a-mm", io->period_a_mm, "known lead of the first plane axis (default: search)");
  id->add_option("--cyclic-period-b-mm", io->period_b_mm, "known lead of the second plane axis (default: search)");
  id->add_flag("--per-run-center", io->per_run_center,
               "Lai model: one centre offset per run instead of Lai's fixed socket shared by all patterns");
  id->callback([io] {
    std::vector<formats::DbbRun> runs;
    for (const auto& f : io->files) runs.push_back(formats::read_dbb_run(f));
    models::dbb::IdentifyOptions opt;
    opt.cyclic_period_a_m = io->period_a_mm * 1e-3;
    opt.cyclic_period_b_m = io->period_b_mm * 1e-3;
    opt.lai_shared_center = !io->per_run_center;
    const auto result = models::dbb::identify(runs, opt);
    if (io->json) {
      std::cout << models::dbb::to_json(result).dump() << "\n";
    } else {
      std::cout << models::dbb::to_text(result);
    }
  });

  auto* simulate = shared_subcommand(app, "simulate", "Produce runs from the virtual machine tool");
  auto* sd = simulate->add_subcommand("dbb", "Write a DBB run traced by the virtual machine tool");
  struct SimOpts {
    std::string machine, out, direction = "ccw", plane = "xy";
    double radius_mm = 100, height_mm = 0, feed = 1000, start_deg = 0, overshoot_deg = 45, rate = 0, t0 = 0;
    std::vector<double> center_mm;
    std::uint64_t seed = 0;
  };
  auto so = std::make_shared<SimOpts>();
  sd->add_option("--machine", so->machine, "machine file (TOML, see docs/machine.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sd->add_option("--radius-mm", so->radius_mm, "circle radius")->required()->check(CLI::PositiveNumber);
  sd->add_option("--height-mm", so->height_mm, "socket height h (Lai), 0 for an in-plane bar")
      ->check(CLI::NonNegativeNumber);
  sd->add_option("--direction", so->direction, "ccw or cw")->check(CLI::IsMember({"ccw", "cw"}));
  sd->add_option("--feed-mm-per-min", so->feed, "feed rate (default 1000)")->check(CLI::PositiveNumber);
  sd->add_option("--plane", so->plane, "xy, xz or yz (default xy)")->check(CLI::IsMember({"xy", "xz", "yz"}));
  sd->add_option("--start-deg", so->start_deg, "start angle of the data arc (default 0)");
  sd->add_option("--overshoot-deg", so->overshoot_deg, "feed-in/feed-out arcs (default 45)")
      ->check(CLI::NonNegativeNumber);
  sd->add_option("--sample-rate-hz", so->rate, "bar sampling rate (default: 10 samples per degree)");
  sd->add_option("--center-mm", so->center_mm, "circle centre in machine coordinates: X Y Z")->expected(3);
  auto* t0_option = sd->add_option("--t0-s", so->t0,
                 "machine time at the start (thermal drift); the run file then carries start_time_s, so runs simulated "
                 "with --t0-s share one machine clock");
  sd->add_option("--seed", so->seed, "noise seed (default: the machine file's)");
  sd->add_option("--out", so->out, "run file to write")->required();
  sd->callback([so, t0_option] {
    const simulators::machine::Machine machine = simulators::machine::Machine::from_file(so->machine);
    constexpr double deg = std::numbers::pi / 180.0;
    simulators::machine::DbbCircleSpec spec;
    spec.radius_m = so->radius_mm * 1e-3;
    spec.height_m = so->height_mm * 1e-3;
    spec.direction = so->direction == "cw" ? formats::DbbDirection::cw : formats::DbbDirection::ccw;
    spec.plane = so->plane == "xz"
                     ? simulators::machine::Plane::xz
                     : (so->plane == "yz" ? simulators::machine::Plane::yz : simulators::machine::Plane::xy);
    spec.feed_m_per_s = so->feed * 1e-3 / 60.0;
    spec.start_angle_rad = so->start_deg * deg;
    spec.overshoot_rad = so->overshoot_deg * deg;
    spec.sample_rate_hz = so->rate;
    if (so->center_mm.size() == 3)
      spec.center = {so->center_mm[0] * 1e-3, so->center_mm[1] * 1e-3, so->center_mm[2] * 1e-3};
    spec.t0_s = so->t0;
    spec.seed = so->seed;
    auto run = simulators::machine::simulate_dbb_run(machine, spec, so->out);
    // Without --t0-s every run would start at machine time 0: no common clock is claimed.
    if (t0_option->count() == 0) run.metadata.erase("start_time_s");
    formats::write_dbb_run(run, so->out);
    std::cout << "wrote " << so->out << ": " << run.angle_rad.size() << " samples, r " << so->radius_mm << " mm, h "
              << so->height_mm << " mm, " << so->direction << "\n";
  });
}

const CommandGroup dbb_group(&add_dbb_commands);

}  // namespace

}  // namespace guideway::cli
