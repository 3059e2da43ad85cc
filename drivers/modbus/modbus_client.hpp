#pragma once
// A Modbus master (client) over TCP or RTU through libmodbus, reduced to what a polling driver
// needs: connect, read one register block, classify every failure. Not thread safe: one owner thread.

#include <array>
#include <bitset>
#include <chrono>
#include <cstdint>
#include <span>
#include <string>

#include "core/toml_access.hpp"
#include "drivers/modbus/register_map.hpp"

struct _modbus;

namespace guideway::drivers::modbus {

struct ModbusEndpoint {
  enum class Kind { tcp, rtu };
  Kind kind = Kind::tcp;
  std::string host = "127.0.0.1";  // tcp
  int port = 502;                  // tcp
  std::string device;              // rtu: /dev/ttyUSB0, /dev/pts/N
  int baud = 19200;                // rtu
  char parity = 'E';               // rtu: 'N', 'E' or 'O'
  int data_bits = 8;               // rtu
  int stop_bits = 1;               // rtu
  int unit_id = 1;                 // slave/unit address
  std::chrono::milliseconds response_timeout{200};

  [[nodiscard]] std::string describe() const;  // "tcp 127.0.0.1:1502 unit 1", "rtu /dev/pts/3 19200 8E1 unit 1"
};

// Reads transport = "tcp" | "rtu" and its keys from a [[device]] table (see docs/protocols.md).
ModbusEndpoint parse_endpoint(const TableReader& table);

enum class ReadStatus { ok, timeout, bad_frame, exception, disconnected };
std::string_view to_string(ReadStatus s) noexcept;
// libmodbus's words for a Modbus exception code ("Slave device or server is busy").
std::string exception_text(int exception_code);

struct ReadResult {
  ReadStatus status = ReadStatus::ok;
  int exception_code = 0;  // Modbus exception code when status == exception
  std::string message;     // libmodbus's words for the failure
};

class ModbusClient {
 public:
  explicit ModbusClient(ModbusEndpoint endpoint);
  ~ModbusClient();
  ModbusClient(const ModbusClient&) = delete;
  ModbusClient& operator=(const ModbusClient&) = delete;

  // Opens the socket or serial line; on failure returns false and sets error.
  bool connect(std::string& error);
  void close() noexcept;
  [[nodiscard]] bool connected() const noexcept { return ctx_ != nullptr; }
  // Reads count registers at address with FC 3/4 into out (out.size() >= count).
  ReadResult read(RegisterFunction function, std::uint16_t address, std::uint16_t count,
                  std::span<std::uint16_t> out) noexcept;
  // Discards whatever is pending on the line (after a bad frame, so the next answer is in step).
  void flush() noexcept;
  // RTU answers carry no transaction id: after a timeout or a bad frame the failed request's answer
  // may still come, and would be taken for the next request of the same size. So the next read first
  // sends a marker whose answer no earlier request's can pass for, and discards every frame before
  // that answer (a serial server answers in turn). The marker is Report Server ID (FC 17, answered
  // with it or an exception, never like a register read); after a probe that heard nothing for a
  // whole response timeout (a server still busy with a late request, or one that ignores FC 17), a
  // read of a register count that no unanswered read asked for (its byte count tells it apart).
  // Counts the frames so discarded (late answers, damaged frames, frames for another unit).
  [[nodiscard]] std::uint64_t stale_answers() const noexcept { return stale_answers_; }
  // The server answered a marker read while probes sent before it went unanswered: it ignores FC 17,
  // and is brought back in step by marker reads only.
  [[nodiscard]] bool probe_ignored() const noexcept { return probe_ignored_; }
  [[nodiscard]] const ModbusEndpoint& endpoint() const noexcept { return endpoint_; }

 private:
  // False when the line could not be brought back in step (nothing answered, or the link is gone).
  // The read about to be sent (function, address, count) chooses the marker read.
  bool resync(RegisterFunction function, std::uint16_t address, std::uint16_t count, ReadResult& failure) noexcept;
  // Report Server ID: in step once every probe sent since the line was last in step is answered.
  enum class ProbeOutcome { in_step, unproven, failed };
  ProbeOutcome resync_by_probe(ReadResult& failure) noexcept;
  bool resync_by_read(RegisterFunction function, std::uint16_t address, std::uint16_t count,
                      ReadResult& failure) noexcept;
  void in_step() noexcept;
  void discard_input() noexcept;  // what has arrived and not been read (never what is still to be sent)

  ModbusEndpoint endpoint_;
  _modbus* ctx_ = nullptr;
  bool resync_needed_ = false;  // RTU: the last read failed, its answer may still be on the way
  int probes_unanswered_ = 0;   // probes sent since the line was last in step, not yet answered
  bool silent_probe_ = false;   // the last probe heard nothing at all
  bool probe_ignored_ = false;  // sticky: the server ignores FC 17
  // Register counts of the reads (FC 3, FC 4) sent since the line was last in step and not
  // answered: their answers may still come, a marker read asks for another count.
  std::array<std::bitset<126>, 2> unanswered_counts_{};
  // The widest read (FC 3, FC 4) answered on this line: registers the server has, for marker reads.
  struct Block {
    std::uint16_t address = 0;
    std::uint16_t count = 0;
  };
  std::array<Block, 2> widest_answered_{};
  std::uint64_t stale_answers_ = 0;
};

}  // namespace guideway::drivers::modbus
