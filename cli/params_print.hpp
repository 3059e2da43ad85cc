#pragma once
// Results as people read them (the `params`, `start --wait`, `replay`, `identify dbb`, `explain` and
// `compensate` commands): labels in words, values in units that mean something and rounded to their
// uncertainty (results/parameters.hpp shown()), no fit internals (condition numbers, solver messages:
// those stay in --json).

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "results/explanation.hpp"
#include "results/params.hpp"
#include "results/result_header.hpp"

namespace guideway::cli {

// "session NAME (KIND on DEVICE)": the line a result opens with, from its header ("?" for what it leaves out).
std::string session_line(const results::ResultHeader& header);
// A PARAMS message: the session line (its header), then print_result() of its PARAMS (results::params_from_json;
// a malformed one throws results::ParamsFormatError), then the files involved.
void print_params(const nlohmann::json& message);
// Every figure group as an aligned table of label, value ± u and unit; for a DBB identification (`guideway identify
// dbb`'s) the runs, the ISO 230-4 figures, the fits in a line each, and "what to fix first" with the errors under
// 1 % of G folded into one line (from its record); the wavelet summary of a profile session.
void print_result(const results::Params& p);

// The summary of several planes' DBB identifications (results::DbbPlanesSummary, models/dbb planes_record): squareness
// and scale mismatch per plane, backlash and scale per axis with the planes they come from and whether they
// agree, "what to fix first" across the machine, the notes.
void print_planes_summary(const results::DbbPlanesSummary& summary);

// Rows of cells as aligned columns (widths as a terminal shows UTF-8), each line after `indent`;
// `right[k]`: column k aligns right (numbers). A row's last cell may run long.
std::string aligned_rows(const std::vector<std::vector<std::string>>& rows, const std::vector<bool>& right,
                         std::string_view indent = "  ");
// An EXPLAIN message in a few lines: held-out RMS before and after, each finding with its physics,
// whether a structured residual is left (`guideway explain` offline prints the full report).
void print_explanation(const results::Explanation& e);

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
  std::string unit;     // as printed ("µm"; "" for a count)
  double per_si = 1.0;  // shown value = SI value * per_si
  int decimals = -1;    // fixed decimals, or -1: six significant digits
};
DisplayUnit display_unit(const std::string& si_unit, double first_value);

// What `guideway watch` has chosen so far: "DEVICE/CHANNEL" -> its display unit.
using ChannelDisplay = std::map<std::string, DisplayUnit>;

// One published message as one readable line (`guideway watch` without --json): the local time it
// arrived, the class, then what matters of it (values with units, states, parameters ± u, ...).
// SAMPLE values in the display units kept in `display` (chosen at a channel's first value), or in SI
// as the daemon sends them when `display` is null (`--si`).
std::string watch_line(const nlohmann::json& message, const ChannelUnits& units, ChannelDisplay* display);

}  // namespace guideway::cli
