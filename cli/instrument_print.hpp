#pragma once
// The instrument lines of the `guideway` commands' readable output: which instrument a result or a
// device is (serial, certificate, dates, the bar's calibrated length) and the warnings that come with it
// (a calibration that had run out, a serial the instrument does not report). Printed to standard
// output with what they concern, so a saved output keeps them.

#include <ostream>

#include <nlohmann/json.hpp>

namespace guideway::cli {

// A PARAMS/EXPLAIN message's "instrument": one line, and its warning (nothing without one).
void print_instrument(const nlohmann::json& message, std::ostream& out);
// A STATUS device's "instrument" and "warnings", indented under its row.
void print_device_instrument(const nlohmann::json& device, int indent, std::ostream& out);
// A reply's "warnings" (the SESSION of `start`), one "WARNING: " line each.
void print_warnings(const nlohmann::json& reply, std::ostream& out);

}  // namespace guideway::cli
