#pragma once
// Sources that feed the CAN and serial emulators from the virtual machine tool: a DBB circle run
// (bar length, the two plane axes' encoders and the normal axis's) and an autocollimator traverse with stops. The
// motion is computed once by guideway::simulators::machine::Machine and replayed in emulator time, repeating when
// it ends. Thread safe (the sources only read an immutable run).

#include <array>
#include <cstddef>
#include <memory>
#include <mutex>
#include <optional>

#include "simulators/emulators/autocollimator_emulator.hpp"
#include "simulators/emulators/dbb_emulator.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::simulators::emulators {

// The axes (0 = x, 1 = y, 2 = z) of the encoders on the DBB bus after the bar: the plane's two, then the
// normal axis's.
std::array<int, 3> bus_axes(machine::Plane plane);

// The computed DBB run shared by the source and tests.
struct DbbMotion {
  machine::DbbRun run;
  machine::Plane plane = machine::Plane::xy;
  double duration_s = 0.0;
  // Bar length, first and second plane axis encoder, then the normal axis's, at motion time t (linear
  // interpolation, t wraps around the motion's duration).
  void at(double t_s, std::span<double> out_m) const;
};
std::shared_ptr<const DbbMotion> make_dbb_motion(const machine::Machine& machine, const machine::DbbCircleSpec& spec);
DbbSource dbb_motion_source(std::shared_ptr<const DbbMotion> motion);

// A DBB test program: several circles one after the other, the machine standing still for `pause_s`
// after each (the operator changes the socket height), then the program repeats. Each circle starts
// at the machine time the previous one ended, so thermal drift carries on across patterns; a pass
// starting at machine time t0_s (the source below simulates each pass at its own time, with noise of
// its own, so that drift and vibration carry on across passes too).
struct DbbProgram {
  std::vector<machine::DbbRun> runs;
  machine::Plane plane = machine::Plane::xy;  // the first circle's: the axes' order on the bus (as DbbMotion's)
  double pause_s = 1.0;
  double duration_s = 0.0;  // of one pass through the program, pauses included
  void at(double t_s, std::span<double> out_m) const;
  // The circle whose motion or pause holds pass time t_s (the last one past the end), and where it starts.
  [[nodiscard]] std::size_t circle_at(double t_s, double& start_s) const;
};
std::shared_ptr<DbbProgram> make_dbb_program(const machine::Machine& machine, std::vector<machine::DbbCircleSpec> specs,
                                             double pause_s, double t0_s = 0.0);

// The program played in emulator time = machine time: pass k is simulated (when the time reaches it) at
// machine time k x the pass's duration, its noise seeded with k. retarget() is the operator's CNC program run
// at another feed (the session's, told by guidewayd: docs/architecture.md "Emulators"): the circle traced
// when it is called ends as it began, and from the next circle on (after its pause, where the last one ended)
// every circle is traced at the new feed, and radius when one is given, the program going on in its order from
// that circle. Thread safe.
class DbbProgramPlayer {
 public:
  DbbProgramPlayer(const machine::Machine& machine, std::vector<machine::DbbCircleSpec> specs, double pause_s);
  // The bus's values (bar length, the plane's two axes, the normal axis) at emulator time t_s.
  void at(double t_s, std::span<double> out_m);
  // radius_m <= 0: each circle keeps its radius. The same feed and radius as now: nothing changes.
  void retarget(double feed_m_per_s, double radius_m = 0.0);
  // A DbbSource that plays this player (shares it).
  [[nodiscard]] static DbbSource source(std::shared_ptr<DbbProgramPlayer> player);

 private:
  void make_pass(long long pass);  // under mutex_

  struct Retarget {
    double feed_m_per_s = 0;
    double radius_m = 0;
    bool seen = false;  // the circle traced when it was asked for is known (pass, circle)
    long long pass = 0;
    std::size_t circle = 0;
  };
  machine::Machine machine_;
  std::mutex mutex_;
  std::vector<machine::DbbCircleSpec> specs_;  // in the order played from origin_s_
  machine::Plane bus_plane_;                   // the first circle's as started: the bus's order stays
  double pause_s_ = 0;
  double origin_s_ = 0;       // emulator time where pass first_pass_ starts (0; a retarget's circle boundary)
  long long first_pass_ = 0;  // the first pass with specs_
  double duration_s_ = 0;     // of one pass of specs_
  long long pass_ = -1;
  std::shared_ptr<const DbbProgram> current_;
  std::optional<Retarget> pending_;
};

// The traverse: the station's angles hold while the carriage dwells there; t wraps around. Between
// stations the reflector is lifted and set down one step on (`move_s`, no reflection), and after the
// last station it is carried back to the start (`return_s`, no reflection): that is how a session
// tells consecutive stations with equal angles apart and finds the start of a traverse. With `passes`
// > 1 the program runs forward, back, forward... over the same stations (Machine::autocollimator_passes:
// the turn station read again after a move), `stations` all of them in the order read, and `return_s`
// follows the last pass.
struct TraverseMotion {
  std::vector<machine::TraverseStation> stations;
  double dwell_s = 1.0;
  double move_s = 0.0;
  double return_s = 0.0;
  [[nodiscard]] double duration_s() const;
  // The station shown at t (during a move or the return: the station just left).
  [[nodiscard]] const machine::TraverseStation& at(double t_s) const;
  // False while the reflector is moved or carried back.
  [[nodiscard]] bool reflecting(double t_s) const;
};
std::shared_ptr<const TraverseMotion> make_traverse_motion(const machine::Machine& machine,
                                                           const machine::TraverseSpec& spec, double move_s = 0.0,
                                                           double return_s = 0.0, std::size_t passes = 1);
// x: yaw, y: pitch (arc-seconds); no reflection during moves and the return (and when the beam is
// blocked by fault injection).
AutocollimatorSource traverse_source(std::shared_ptr<const TraverseMotion> motion);

// A machine with a few typical errors (squareness, servo mismatch, pitch/yaw of X, backlash) for the
// emulators when no machine file is given.
machine::MachineConfig demo_machine_config();

}  // namespace guideway::simulators::emulators
