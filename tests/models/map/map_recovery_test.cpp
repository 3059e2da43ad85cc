// The error map on two machines (issue 44's proof): the example machine and a second machine with other values
// for all 21 errors, each measured by a simulated day (three-plane ballbar, autocollimator traverses and the 1-D
// artifact on every axis): every error function against the machine's (RMS over its travel, against its u), the
// volumetric accuracy against the machine's own, and the map's tables loaded into the virtual machine: its
// volumetric accuracy after at most a third of before. The tables printed here are docs/map.md's.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "models/map/exports.hpp"
#include "models/map/map_json.hpp"
#include "models/map/volumetric.hpp"
#include "map_test_support.hpp"
#include "sanitizer_build.hpp"

namespace {

using namespace guideway;
using namespace guideway::map_test;

const std::string kWork = GUIDEWAY_BINARY_DIR "/map_recovery_work";

// The machine's own volumetric accuracy over the map's grid (the controller's corrections loaded).
mm::VolumetricAccuracy machine_accuracy(const sm::Machine& m, const mm::ErrorMap& map,
                                        const sm::ControllerCorrection& correction = {}) {
  const auto at = mm::volume_grid(map.travel, {11, 11, 11});
  std::vector<mm::Vec3> e;
  for (const auto& p : at) e.push_back(sm::static_tool_error(m, p, correction));
  return mm::field_accuracy(at, e);
}

struct Recovery {
  int beyond_2u = 0;
  double worst_ratio = 0;
};

// The map of a day on `machine_file`: its 21 errors against the machine's, printed as a table.
Recovery check_machine(const std::string& machine_file, const std::string& dir) {
  const sm::Machine m(sm::load_machine_config(machine_file));
  const simulators::emulators::DayPlan plan;
  const mm::MapFit fit = mm::fit_map(simulated_day(m, plan, dir));
  const mm::ErrorMap& map = fit.map;
  const mm::ErrorMap truth = sm::truth_map(m.config(), map.travel);
  Recovery r;
  std::printf("%s: the 21 errors (RMS over the travel; ratio = RMS of found - truth over RMS of u)\n",
              m.config().name.c_str());
  std::printf("| error | truth RMS | found RMS | u | found - truth | ratio | determined by |\n|---|---:|---:|---:|---:|---:|---|\n");
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < mm::components; ++c) {
      const auto& f = map.function(j, c);
      EXPECT_TRUE(f.determined) << mm::function_name(j, c) << ": " << f.why;
      if (!f.determined) continue;
      const Against a = against_truth(map, m.config(), j, c);
      const char* unit = c < 3 ? "um" : "urad";
      std::printf("| %s | %.4f %s | %.4f %s | %.4f | %.4f | %.2f | %s |\n", mm::function_name(j, c).c_str(),
                  a.truth_rms * 1e6, unit, a.found_rms * 1e6, unit, a.u_rms * 1e6, a.diff_rms * 1e6, a.ratio(),
                  f.determined_by.c_str());
      EXPECT_LT(a.ratio(), 3.0) << mm::function_name(j, c);
      if (a.ratio() > 2.0) ++r.beyond_2u;
      r.worst_ratio = std::max(r.worst_ratio, a.ratio());
    }
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& q = map.squareness[i];
    EXPECT_TRUE(q.determined) << q.plane << ": " << q.why;
    if (!q.determined) continue;
    const double u = std::sqrt(map.covariance_at(q.parameter, q.parameter));
    const double ratio = std::abs(q.value_rad - truth.squareness[i].value_rad) / u;
    const double sign = mm::iso_squareness_sign(static_cast<int>(i));
    std::printf("| %s (squareness %s, ISO sign) | %.3f urad | %.3f urad | %.3f | %.3f | %.2f | %s |\n",
                mm::iso_squareness_name(static_cast<int>(i)), q.plane.c_str(), sign * truth.squareness[i].value_rad * 1e6,
                sign * q.value_rad * 1e6, u * 1e6, sign * (q.value_rad - truth.squareness[i].value_rad) * 1e6, ratio,
                q.determined_by.c_str());
    EXPECT_LT(ratio, 3.0) << q.plane;
    if (ratio > 2.0) ++r.beyond_2u;
    r.worst_ratio = std::max(r.worst_ratio, ratio);
  }

  // Volumetric accuracy: the map's against the machine's own.
  const auto va = mm::volumetric_accuracy(map);
  const auto truth_va = machine_accuracy(m, map);
  std::printf("volumetric accuracy: map %.3f +- %.3f um, machine %.3f um (difference %.2f u)\n", va.value_m * 1e6,
              va.u_m * 1e6, truth_va.value_m * 1e6, (va.value_m - truth_va.value_m) / va.u_m);
  EXPECT_TRUE(va.missing.empty());
  EXPECT_LE(std::abs(va.value_m - truth_va.value_m), 2 * va.u_m);

  // The tables as a controller loads them, on the machine.
  const std::string out = dir + "/tables";
  std::filesystem::create_directories(out);
  for (const auto& f : mm::map_exports(map, fit.backlash, {}, "recovery")) {
    FILE* file = std::fopen((out + "/" + f.name).c_str(), "w");
    std::fputs(f.content.c_str(), file);
    std::fclose(file);
  }
  const mm::TableMap tables = mm::read_table_map(out);
  sm::ControllerCorrection correction;
  const mm::Vec3 tool = m.config().tool_offset;
  correction.volumetric = [&tables, tool](const sm::Vec3& p) {
    const auto e = mm::table_tool_error(tables, p, tool);
    return sm::Vec3{-e[0], -e[1], -e[2]};
  };
  const auto after = machine_accuracy(m, map, correction);
  std::printf("compensated on the virtual machine: before %.3f um, after %.3f um (%.4f of before)\n",
              truth_va.value_m * 1e6, after.value_m * 1e6, after.value_m / truth_va.value_m);
  EXPECT_LE(after.value_m, truth_va.value_m / 3);
  return r;
}

// Of 21 quantities each within 2 u with 95 % probability, one beyond is no surprise, several would be: the
// statistics test below holds the uncertainties to it over many days.
TEST(MapRecovery, ExampleMachine) {
  const Recovery r = check_machine(GUIDEWAY_SOURCE_DIR "/config/machine-example.toml", kWork + "/example");
  EXPECT_LE(r.beyond_2u, 1);
}

TEST(MapRecovery, SecondMachine) {
  const Recovery r = check_machine(write_second_machine(kWork), kWork + "/second");
  EXPECT_LE(r.beyond_2u, 1);
}

// The uncertainties are honest over days: over 30 days of the example machine (other noise each), the 21 errors
// fall beyond 2 u in at most 7 % of the cases and their squared ratios average near 1; the volumetric accuracy
// falls within its u about as often as a Gaussian's.
TEST(MapRecovery, UncertaintiesCoverTheTruthOverDays) {
#if defined(GUIDEWAY_SANITIZED_ADDRESS)
  GTEST_SKIP() << "a statistical test over 30 simulated days: run in the Release build, not under ASan";
#endif
  const sm::Machine m(sm::load_machine_config(GUIDEWAY_SOURCE_DIR "/config/machine-example.toml"));
  int n = 0, beyond = 0, va_within = 0;
  double sum_r2 = 0;
  const int days = 30;
  for (int d = 1; d <= days; ++d) {
    simulators::emulators::DayPlan plan;
    plan.seed = static_cast<std::uint64_t>(d) * 1009;
    plan.runout = false;
    const mm::MapFit fit = mm::fit_map(simulated_day(m, plan, kWork + "/days"));
    const mm::ErrorMap truth = sm::truth_map(m.config(), fit.map.travel);
    for (int j = 0; j < 3; ++j)
      for (int c = 0; c < mm::components; ++c) {
        const double r = against_truth(fit.map, m.config(), j, c).ratio();
        sum_r2 += r * r;
        beyond += r > 2.0;
        ++n;
      }
    for (std::size_t i = 0; i < 3; ++i) {
      const auto& q = fit.map.squareness[i];
      const double r = (q.value_rad - truth.squareness[i].value_rad) / std::sqrt(fit.map.covariance_at(q.parameter, q.parameter));
      sum_r2 += r * r;
      beyond += std::abs(r) > 2.0;
      ++n;
    }
    mm::VolumetricOptions vo;
    vo.points = {7, 7, 7};
    vo.draws = 100;
    const auto va = mm::volumetric_accuracy(fit.map, vo);
    const auto at = mm::volume_grid(fit.map.travel, vo.points);
    std::vector<mm::Vec3> e;
    for (const auto& p : at) e.push_back(sm::static_tool_error(m, p));
    va_within += std::abs(va.value_m - mm::field_accuracy(at, e).value_m) <= va.u_m;
  }
  std::printf("over %d days: %d of %d beyond 2 u (%.1f %%), mean squared ratio %.2f; volumetric accuracy within 1 u "
              "on %d of %d days\n",
              days, beyond, n, 100.0 * beyond / n, sum_r2 / n, va_within, days);
  EXPECT_LE(beyond, static_cast<int>(0.07 * n));
  EXPECT_GT(sum_r2 / n, 0.6);
  EXPECT_LT(sum_r2 / n, 1.4);
  EXPECT_GE(va_within, days / 2);
}

}  // namespace
