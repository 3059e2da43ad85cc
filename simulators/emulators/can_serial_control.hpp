#pragma once
// The control channel of the CAN and serial emulator processes: fault-injection commands, one per
// line on stdin ("garbage 10", "stall 0.5", "disconnect", "quit"), each answered on stdout with
// "ok ..." or "error ...". Runs until "quit", end of the duration, or SIGINT/SIGTERM.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace guideway::simulators::emulators {

// Returns false (with a message) for an unknown or malformed command.
using ControlHandler = std::function<bool(const std::vector<std::string>& words, std::string& message)>;

// Blocks SIGINT/SIGTERM for the calling thread (call before starting other threads, so they inherit
// the mask) and returns once stopped. duration_s <= 0: no limit.
void block_stop_signals();
int run_control_loop(const ControlHandler& handle, double duration_s);

// Parses words[i] as a number; false when missing or malformed.
bool word_to_int(const std::vector<std::string>& words, std::size_t i, int& out);
bool word_to_double(const std::vector<std::string>& words, std::size_t i, double& out);
// An unsigned 32-bit number, decimal or 0x-hexadecimal ("0x08000022").
bool word_to_u32(const std::vector<std::string>& words, std::size_t i, std::uint32_t& out);

}  // namespace guideway::simulators::emulators
