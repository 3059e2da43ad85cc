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
// One published message as one readable line (`guideway watch` without --json): the local time it
// arrived, the class, then what matters of it (values with units, states, parameters +/- u, ...).
std::string watch_line(const nlohmann::json& message, const ChannelUnits& units);

}  // namespace guideway::cli
