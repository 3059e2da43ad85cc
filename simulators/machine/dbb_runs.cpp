// DBB runs from the virtual machine tool (dbb_runs.hpp): each circle's data arc as the run files the identification
// reads.
#include "simulators/machine/dbb_runs.hpp"

#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "core/number_format.hpp"

namespace guideway::simulators::machine {

formats::DbbRun simulate_dbb_run(const Machine& machine, const DbbCircleSpec& spec, const std::string& source,
                                 AngleSource angles) {
  const machine::DbbRun raw = machine.dbb_circle(spec);
  formats::DbbRun run;
  run.source = source;
  run.radius_m = spec.radius_m;
  run.height_m = spec.height_m;
  run.direction = spec.direction;
  run.feed_m_per_s = spec.feed_m_per_s;
  run.plane = spec.plane == machine::Plane::xy ? "xy" : (spec.plane == machine::Plane::xz ? "xz" : "yz");
  const int a = spec.plane == machine::Plane::yz ? 1 : 0;
  const int b = spec.plane == machine::Plane::xy ? 1 : 2;
  run.center_a_m = spec.center[static_cast<std::size_t>(a)];
  run.center_b_m = spec.center[static_cast<std::size_t>(b)];
  run.metadata["center_a_mm"] = shortest(run.center_a_m * 1e3);
  run.metadata["center_b_mm"] = shortest(run.center_b_m * 1e3);
  run.metadata["machine"] = machine.config().name;
  std::ostringstream seed;
  seed << spec.seed;
  run.metadata["seed"] = seed.str();
  run.metadata["source"] = "guideway simulate dbb (virtual machine tool)";
  run.metadata["angle_source"] = angles == AngleSource::encoders ? "encoders" : "commanded";
  if (spec.data_arc_rad < 2.0 * std::numbers::pi - 1e-9) {
    run.data_arc_rad = spec.data_arc_rad;
    run.metadata["data_arc_deg"] = shortest(spec.data_arc_rad * 180.0 / std::numbers::pi);
  }
  double t_start = -1;
  for (const auto& s : raw.samples) {
    if (!s.in_data_arc) continue;
    if (t_start < 0) t_start = s.t_s;
    run.t_s.push_back(s.t_s - t_start);
    double angle = s.angle_rad;
    if (angles == AngleSource::encoders) {
      // Where the drives were, about the commanded centre, on the commanded angle's turn.
      const double e = std::atan2(s.encoder[static_cast<std::size_t>(b)] - run.center_b_m,
                                  s.encoder[static_cast<std::size_t>(a)] - run.center_a_m);
      angle += std::remainder(e - angle, 2.0 * 3.141592653589793);
    }
    run.angle_rad.push_back(angle);
    run.dL_m.push_back(s.dL_m);
  }
  // Machine time of the first data sample: runs simulated on one machine clock (their spec.t0_s) share it.
  std::ostringstream start;
  start.precision(17);
  start << t_start;
  run.metadata["start_time_s"] = start.str();
  return run;
}

formats::DbbRun with_dropout(const formats::DbbRun& run, double start_s, double duration_s) {
  formats::DbbRun kept = run;
  kept.t_s.clear();
  kept.angle_rad.clear();
  kept.dL_m.clear();
  for (std::size_t i = 0; i < run.t_s.size(); ++i) {
    if (run.t_s[i] > start_s && run.t_s[i] < start_s + duration_s) continue;
    kept.t_s.push_back(run.t_s[i]);
    kept.angle_rad.push_back(run.angle_rad[i]);
    kept.dL_m.push_back(run.dL_m[i]);
  }
  formats::validate_dbb_run(kept);
  return kept;
}

DbbCircleSpec circle_spec_of(const formats::DbbRun& run, const Vec3& center) {
  DbbCircleSpec spec;
  spec.radius_m = run.radius_m;
  spec.height_m = run.height_m;
  spec.direction = run.direction;
  spec.plane = run.plane == "xz" ? Plane::xz : (run.plane == "yz" ? Plane::yz : Plane::xy);
  spec.feed_m_per_s = run.feed_m_per_s;
  if (!run.angle_rad.empty()) spec.start_angle_rad = std::remainder(run.angle_rad.front(), 2.0 * 3.141592653589793);
  // A partial arc as the run file states it (data_arc_deg), else as long as its samples reach.
  if (run.data_arc_rad > 0)
    spec.data_arc_rad = run.data_arc_rad;
  else if (run.angle_rad.size() > 1 && !formats::dbb_run_full_circle(run))
    spec.data_arc_rad = formats::dbb_run_arc_rad(run);
  spec.center = center;
  return spec;
}

JointCompensation joint_compensation(const std::vector<formats::CompTriplet>& table) {
  JointCompensation c;
  for (const auto& t : table) {
    c.nominal_m.push_back(t.nominal_mm * 1e-3);
    c.forward_m.push_back(t.forward_mm * 1e-3);
    c.reverse_m.push_back(t.reverse_mm * 1e-3);
  }
  return c;
}

std::vector<CrossCompensation> cross_compensation(const std::vector<formats::CrossCorrectionRow>& rows) {
  const auto axis = [](const std::string& a) {
    if (a == "x") return Axis::x;
    if (a == "y") return Axis::y;
    if (a == "z") return Axis::z;
    throw std::invalid_argument("cross-axis correction: axis \"" + a + "\" is not x, y or z");
  };
  std::vector<CrossCompensation> out;
  for (const auto& r : rows) {
    if (out.empty() || out.back().moving != axis(r.moving_axis) || out.back().corrected != axis(r.corrected_axis))
      out.push_back({axis(r.moving_axis), axis(r.corrected_axis), {}, {}});
    out.back().nominal_m.push_back(r.position_mm * 1e-3);
    out.back().correction_m.push_back(r.correction_mm * 1e-3);
  }
  return out;
}

std::vector<formats::DbbRun> retrace_dbb(const MachineConfig& machine, const ControllerCorrection& correction,
                                         const std::vector<formats::DbbRun>& runs, const Vec3& center,
                                         const std::string& tag) {
  MachineConfig with = machine;
  with.controller = correction;
  const Machine m(with);
  std::vector<formats::DbbRun> out;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    DbbCircleSpec spec = circle_spec_of(runs[k], center);
    if (const auto s = runs[k].metadata.find("seed"); s != runs[k].metadata.end()) {
      try {
        spec.seed = std::stoull(s->second);
      } catch (const std::exception&) {
        spec.seed = 0;
      }
    }
    // The angles as the given run has them: a live session's are the axis encoders'.
    const auto source = runs[k].metadata.find("angle_source");
    const AngleSource angles = source != runs[k].metadata.end() && source->second == "encoders"
                                   ? AngleSource::encoders
                                   : AngleSource::commanded;
    const std::string name =
        tag + "_" + std::to_string(k + 1) + (runs[k].direction == formats::DbbDirection::ccw ? "_ccw" : "_cw");
    formats::DbbRun run = simulate_dbb_run(m, spec, name, angles);
    run.metadata.erase("start_time_s");
    run.metadata["compensation"] = tag;
    out.push_back(std::move(run));
  }
  return out;
}

RemeasuredRuns remeasure_dbb(const MachineConfig& machine, const ControllerCorrection& correction,
                             const std::vector<formats::DbbRun>& runs, const Vec3& center) {
  return {retrace_dbb(machine, {}, runs, center, "before"), retrace_dbb(machine, correction, runs, center, "after")};
}

models::compensation::Retrace dbb_retrace(const MachineConfig& machine, const std::vector<formats::DbbRun>& runs) {
  using models::compensation::Correction;
  // Each correction as the controller loads it, read once: the verification traces many sets of them.
  auto read = std::make_shared<std::map<std::string, ControllerCorrection>>();  // by file: a set's are distinct
  const auto alone = [read](const Correction* c) -> const ControllerCorrection& {
    auto it = read->find(c->file);
    if (it != read->end()) return it->second;
    ControllerCorrection one;
    switch (c->kind) {
      case Correction::Kind::table:
        one.tables[static_cast<std::size_t>(c->joint)] = joint_compensation(formats::read_linuxcnc_comp(c->path));
        break;
      case Correction::Kind::skew:
        (c->plane == "xy" ? one.skew.xy : (c->plane == "xz" ? one.skew.xz : one.skew.yz)) = c->skew_rad;
        break;
      case Correction::Kind::cross:
        one.cross = cross_compensation(formats::read_straightness_csv(c->path));
        break;
    }
    return read->emplace(c->file, std::move(one)).first->second;
  };
  const auto combined = [alone](const std::vector<const Correction*>& set) {
    ControllerCorrection c;
    for (const Correction* x : set) {
      const ControllerCorrection& a = alone(x);
      for (std::size_t j = 0; j < 3; ++j)
        if (!a.tables[j].empty()) c.tables[j] = a.tables[j];
      c.skew.xy += a.skew.xy;
      c.skew.xz += a.skew.xz;
      c.skew.yz += a.skew.yz;
      c.cross.insert(c.cross.end(), a.cross.begin(), a.cross.end());
    }
    return c;
  };
  models::compensation::Retrace r;
  r.before_and_after = [machine, runs, combined](const std::vector<const Correction*>& all,
                                                 const std::array<double, 3>& center) {
    RemeasuredRuns m = remeasure_dbb(machine, combined(all), runs, center);
    return std::pair{std::move(m.before), std::move(m.after)};
  };
  r.with = [machine, runs, combined](const std::vector<const Correction*>& set, const std::array<double, 3>& center) {
    return retrace_dbb(machine, combined(set), runs, center, "after");
  };
  return r;
}

}  // namespace guideway::simulators::machine
