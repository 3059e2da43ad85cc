#pragma once
// Human-readable form of a PARAMS message (the `params`, `start --wait` and `replay` commands).

#include <map>
#include <string>

#include <nlohmann/json.hpp>

namespace guideway::cli {

// Prints every group of {"name":{"value":..,"u":..}} as an aligned table, then the fit summaries, the
// wavelet summary of a profile session, and the files involved.
void print_params(const nlohmann::json& p);
// An EXPLAIN message in a few lines: held-out RMS before and after, each finding with its physics,
// whether a structured residual is left (`guideway explain` offline prints the full report).
void print_explanation(const nlohmann::json& e);

// A daemon reply that is an ERROR: with `json` (the command's --json) it is printed to standard output
// unchanged, like every other daemon message, then thrown as "daemon: MESSAGE" (stderr, exit 1).
void throw_if_error_reply(const nlohmann::json& reply, bool json);

// "DEVICE/CHANNEL" -> unit, from a STATUS message's devices[].channels.
using ChannelUnits = std::map<std::string, std::string>;

// How a channel's values are shown: in the units the rest of the tool speaks. A length in mm when the
// channel's first value is 1 mm or more (an axis position, a bar length: 0.1 µm resolution), else in µm
// (a deviation, a gauge reading: 1 nm); an angle in arcsec. Chosen once per channel so that a column
// never switches unit; other units as they are.
struct DisplayUnit {
  std::string unit;      // as printed ("µm"; "" for a count)
  double per_si = 1.0;   // shown value = SI value * per_si
  int decimals = -1;     // fixed decimals, or -1: six significant digits
};
DisplayUnit display_unit(const std::string& si_unit, double first_value);

// What `guideway watch` has chosen so far: "DEVICE/CHANNEL" -> its display unit.
using ChannelDisplay = std::map<std::string, DisplayUnit>;

// One published message as one readable line (`guideway watch` without --json): the local time it
// arrived, the class, then what matters of it (values with units, states, parameters +/- u, ...).
// SAMPLE values in the display units kept in `display` (chosen at a channel's first value), or in SI
// as the daemon sends them when `display` is null (`--si`).
std::string watch_line(const nlohmann::json& message, const ChannelUnits& units, ChannelDisplay* display);

}  // namespace guideway::cli
