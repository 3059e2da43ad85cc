#pragma once
// An emulated inductance-micrometer gauge amplifier: a real libmodbus server (Modbus TCP on a
// socket, or Modbus RTU on a pseudo-terminal joined to the client's pseudo-terminal by a byte
// bridge) whose registers follow a reading source, with switchable fault injection. Optionally it
// also buffers samples taken at a fixed rate in a ring of registers with a sample counter
// (drivers::modbus::SampleRingMap), as amplifiers and data loggers that sample faster than a master polls do.
// Thread safe: start/stop from the owning thread; inject/disconnect_for/served from any thread.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/sample_ring.hpp"

namespace guideway::simulators::emulators {

// What the probe sees at time t_s (seconds since the emulator started).
struct MicrometerPoint {
  double value_m = 0.0;
  bool out_of_range = false;
  bool probe_missing = false;
};
using MicrometerSource = std::function<MicrometerPoint(double t_s)>;

// A spindle run-out revolution seen by a probe on a thrust plate: eccentricity plus a 2nd harmonic.
MicrometerSource runout_source(double rpm = 60.0, double eccentricity_m = 2e-6, double second_harmonic_m = 0.3e-6);

enum class ModbusFault {
  exception,  // answer with exception 6 (server busy)
  stall,      // no answer at all (the client times out)
  garbage,    // random bytes instead of the answer
  truncate,   // the first half of the answer only
  bad_crc,    // RTU: answer with a wrong CRC; TCP (no CRC): a damaged transaction id
  burst,      // the answer three times in a row (frames faster than the poll rate)
  late,       // the right answer, but late_answer_ms late (after the client gave up on it)
};
std::string_view to_string(ModbusFault f) noexcept;
bool modbus_fault_from_string(std::string_view s, ModbusFault& out) noexcept;

// One reading the server answered normally (the driver should have received it).
struct ServedReading {
  std::uint64_t request = 0;  // 0-based index of the request among all requests received
  double value_m = 0.0;       // as encoded in the registers, i.e. quantized like the driver decodes it
  std::uint32_t flags = 0;    // SampleFlag bits the driver should report
};

class MicrometerEmulator {
 public:
  struct Options {
    drivers::modbus::RegisterMap map;
    int unit_id = 1;
    MicrometerSource source = runout_source();
    // The sample ring: sample k (k = 0, 1, ... since start) is source(k / sample_rate_hz), taken at
    // start + k / rate, numbered ring_counter_start + k (mod 2^32) in the counter.
    std::optional<drivers::modbus::SampleRingMap> ring;
    std::uint32_t ring_counter_start = 0;
    // How late a `late` answer comes; the server answers nothing else meanwhile, like a slow device.
    std::chrono::milliseconds late_answer_ms{700};
    // false: Report Server ID (FC 17) goes unanswered, like a server that ignores what it does not
    // implement instead of answering an exception as the standard asks.
    bool answers_report_server_id = true;
  };
  explicit MicrometerEmulator(Options options);
  ~MicrometerEmulator();
  MicrometerEmulator(const MicrometerEmulator&) = delete;
  MicrometerEmulator& operator=(const MicrometerEmulator&) = delete;

  // Modbus TCP server on host:port (port 0: any free port). Returns the port, or -1 with error set.
  int start_tcp(const std::string& host, int port, std::string& error);
  // Modbus RTU server behind a pseudo-terminal pair; returns the client's pty path ("" with error set).
  std::string start_rtu(int baud, char parity, int data_bits, int stop_bits, std::string& error);
  void stop();

  // The next `count` register reads get fault f (queued after faults already pending).
  void inject(ModbusFault f, int count = 1);
  // The line goes dead for d: TCP closes the connection and refuses new ones; RTU drops all bytes.
  void disconnect_for(std::chrono::milliseconds d);
  [[nodiscard]] std::vector<ServedReading> served() const;
  // Ring mode: the samples taken since the ring's (re)start as the counter showed them, at each of the
  // last max_served_counters counter reads answered (what a master can know was overwritten, when).
  [[nodiscard]] std::vector<std::uint64_t> served_counters() const;
  static constexpr std::size_t max_served_counters = 1 << 16;
  [[nodiscard]] std::uint64_t requests() const noexcept { return requests_.load(); }
  [[nodiscard]] std::uint64_t connections() const noexcept { return connections_.load(); }
  // The amplifier restarted `ago` before the next request: its counter starts again at 0 (sample k of
  // the new run is source(k / rate)); slots not yet rewritten keep the old run's samples.
  void restart_ring(std::chrono::milliseconds ago);
  // CLOCK_MONOTONIC (ns) of the (re)start: ring sample k was taken at ring_start_ns() + k / rate.
  [[nodiscard]] std::int64_t ring_start_ns() const noexcept;

 private:
  void tcp_loop(int port);
  void rtu_loop();
  void bridge_loop();
  void handle(const std::uint8_t* query, int length, int fd, bool rtu);
  bool line_down() const;
  void fill_ring(double t_s);  // the ring and counter as the amplifier shows them at t_s
  void set_register(std::uint32_t address, std::uint16_t value);
  void record_counter(std::uint16_t start, std::uint16_t count);  // a read answered: its counter, if it covers it

  Options options_;
  std::string host_;
  void* ctx_ = nullptr;      // modbus_t*
  void* mapping_ = nullptr;  // modbus_mapping_t*
  std::uint32_t mapping_start_ = 0;
  std::uint64_t ring_taken_ = 0;                   // samples written into the ring so far (server thread)
  std::chrono::steady_clock::time_point ring_t0_;  // the ring's (re)start (mutex_)
  std::atomic<std::int64_t> ring_restart_ago_ns_{-1};
  int listen_fd_ = -1;
  int pty_server_master_ = -1, pty_client_master_ = -1, pty_server_slave_ = -1, pty_client_slave_ = -1;
  std::atomic<bool> running_{false};
  std::thread server_thread_, bridge_thread_;
  std::chrono::steady_clock::time_point t0_;
  mutable std::mutex mutex_;
  std::deque<ModbusFault> pending_;
  std::chrono::steady_clock::time_point down_until_{};
  bool drop_connection_ = false;
  std::vector<ServedReading> served_;
  std::deque<std::uint64_t> served_counters_;
  std::atomic<std::uint64_t> requests_{0};
  std::atomic<std::uint64_t> connections_{0};
  std::uint32_t rng_ = 0x9e3779b9u;
};

// Runs `command` lines against an emulator (used by guideway-emulate on stdin):
// "fault <name> [count]", "disconnect <ms>". Returns false with a message for an unknown command.
bool apply_micrometer_command(MicrometerEmulator& emulator, const std::string& line, std::string& message);

}  // namespace guideway::simulators::emulators
