#pragma once
// guideway-linuxcnc-bridge: LinuxCNC's servo periods to every Guideway process that asks for them.
//
// LinuxCNC's `sampler` component (loaded by linuxcnc/guideway-bridge.hal) copies the pins of every servo
// period into a realtime FIFO; `halsampler -t`, the bridge's child, prints them. The bridge reads those
// lines and serves them, with a header naming the columns, on a Unix stream socket to each client
// (guidewayd's linuxcnc-hal device, guideway-emulate dbb --follow): the stream of drivers/linuxcnc/
// hal_stream.hpp. Nothing is lost silently: halsampler's overruns (the FIFO was full), a client too slow
// for its queue and lines that are not a period are counted, each client is told `! lost N why` in its
// stream, and the counts go to stderr (LinuxCNC's log) when the bridge ends. It ends with halsampler (which
// LinuxCNC stops at shutdown: `halcmd unload all`) or on SIGTERM/SIGINT.
// One thread: an epoll loop over the socket, the clients, halsampler's output and a signalfd.

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace guideway::drivers::linuxcnc {

struct BridgeOptions {
  std::string socket_path = "/run/guideway-linuxcnc/bridge.sock";
  unsigned socket_mode = 0666;  // guidewayd (user guideway) reads what LinuxCNC's user's bridge serves
  // The program whose stdout carries the periods (halsampler -t, or a test's stand-in).
  std::vector<std::string> source_command = {"halsampler", "-t", "-c", "0"};
  std::vector<std::string> columns;  // the header's names, one per sampled pin
  std::int64_t period_ns = 1000000;
  std::size_t client_queue_bytes = 32u << 20;  // about 4 min of the default columns at 1 kHz
};

struct BridgeCounters {
  std::uint64_t periods = 0;        // period lines read from the source
  std::uint64_t lost_overrun = 0;   // periods the source skipped (halsampler overrun: the FIFO was full)
  std::uint64_t bad_lines = 0;      // lines that were not a period of the columns
  std::uint64_t clients = 0;        // connections served
  std::uint64_t lost_to_clients = 0;  // periods dropped for clients too slow to take them
};

// Runs until the source ends or a stop signal; returns the exit code (0: the source ended or a stop was
// asked, 1: the bridge could not start). Progress and the counters go to `log`.
int run_bridge(const BridgeOptions& options, std::ostream& log, BridgeCounters* counters = nullptr);

}  // namespace guideway::drivers::linuxcnc
