#pragma once
// The virtual machine's 21 geometric errors as the error map defines them (docs/map.md "What a map is relative
// to"), to prove a fitted map against: each error function less what the map's gauge leaves out (its mean
// over the travel, and for a straightness its least-squares line), the squarenesses that the straightness
// slopes and the angles' constant parts make (first order), and the machine's static error anywhere in the
// volume, with or without a controller's corrections. Pure functions; thread safe.

#include <array>

#include "models/map/error_map.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::simulators::machine {

// What the machine's function (axis, component) is without the map's gauge, at position u (m): the
// positioning error (with the scale and the lead screw's cyclic error) less its mean over the travel; a
// straightness less its least-squares line; an angle less its mean.
double truth_value(const MachineConfig& machine, const std::array<models::map::Travel, 3>& travel, int axis,
                   int component, double u_m);

// The machine as an error map: every function in Legendre orders up to `max_order` over the travel (exact for
// a polynomial machine of lower degree), every squareness as the map defines it; all determined, no
// covariance. Its tool offset is the machine's.
models::map::ErrorMap truth_map(const MachineConfig& machine, const std::array<models::map::Travel, 3>& travel,
                                int max_order = 10);

// The machine's static error of the tool point at commanded axis positions (approached moving +), with the
// controller's `correction`: the exact chain less the commanded position and the tool offset.
models::map::Vec3 static_tool_error(const Machine& machine, const Vec3& commanded,
                                    const ControllerCorrection& correction = {});

}  // namespace guideway::simulators::machine
