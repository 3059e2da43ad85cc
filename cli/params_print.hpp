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

namespace guideway::cli {

// The session line, then print_result(), then the files involved.
void print_params(const nlohmann::json& p);
// Every group of {"name":{"value":..,"u":..}} as an aligned table of label, value ± u and unit; for a
// DBB identification (`guideway identify dbb --json`'s shape) the runs, the ISO 230-4 figures, the fits
// in a line each, and "what to fix first" with the errors under 1 % of G folded into one line; the
// wavelet summary of a profile session.
void print_result(const nlohmann::json& p);

// Rows of cells as aligned columns (widths as a terminal shows UTF-8), each line after `indent`;
// `right[k]`: column k aligns right (numbers). A row's last cell may run long.
std::string aligned_rows(const std::vector<std::vector<std::string>>& rows, const std::vector<bool>& right,
                         std::string_view indent = "  ");
// An EXPLAIN message in a few lines: held-out RMS before and after, each finding with its physics,
// whether a structured residual is left (`guideway explain` offline prints the full report).
void print_explanation(const nlohmann::json& e);

// A daemon reply that is an ERROR: with `json` (the command's --json) it is printed to standard output
// unchanged, like every other daemon message, then thrown as "daemon: MESSAGE" (stderr, exit 1).
void throw_if_error_reply(const nlohmann::json& reply, bool json);

// "DEVICE/CHANNEL" -> unit, from a STATUS message's devices[].channels.
using ChannelUnits = std::map<std::string, std::string>;
// One published message as one readable line (`guideway watch` without --json): the local time it
// arrived, the class, then what matters of it (values with units, states, parameters +/- u, ...).
std::string watch_line(const nlohmann::json& message, const ChannelUnits& units);

}  // namespace guideway::cli
