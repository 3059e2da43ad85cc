// A Modbus master over TCP or RTU through libmodbus (modbus_client.hpp): connect, read one register block, classify
// every failure.
#include "drivers/modbus/modbus_client.hpp"

#include <modbus/modbus.h>

#include <termios.h>

#include <cerrno>

namespace guideway::drivers::modbus {

std::string ModbusEndpoint::describe() const {
  if (kind == Kind::tcp) return "tcp " + host + ":" + std::to_string(port) + " unit " + std::to_string(unit_id);
  return "rtu " + device + " " + std::to_string(baud) + " " + std::to_string(data_bits) + parity +
         std::to_string(stop_bits) + " unit " + std::to_string(unit_id);
}

ModbusEndpoint parse_endpoint(const TableReader& t) {
  ModbusEndpoint e;
  e.kind =
      t.get_choice("transport", "tcp", {"tcp", "rtu"}) == "rtu" ? ModbusEndpoint::Kind::rtu : ModbusEndpoint::Kind::tcp;
  if (e.kind == ModbusEndpoint::Kind::tcp) {
    e.host = t.get_string("host", "127.0.0.1");
    e.port = static_cast<int>(t.get_int("port", 502, 1, 65535));
  } else {
    e.device = t.require_string("device");
    if (e.device.empty()) t.fail("device", "must name a serial device, e.g. \"/dev/ttyUSB0\"");
    e.baud = static_cast<int>(t.get_int("baud", 19200, 50, 4000000));
    e.parity = t.get_choice("parity", "E", {"N", "E", "O"})[0];
    e.data_bits = static_cast<int>(t.get_int("data_bits", 8, 5, 8));
    e.stop_bits = static_cast<int>(t.get_int("stop_bits", 1, 1, 2));
  }
  e.unit_id = static_cast<int>(t.get_int("unit_id", 1, 1, 247));
  e.response_timeout = std::chrono::milliseconds(t.get_int("response_timeout_ms", 200, 1, 60000));
  return e;
}

std::string_view to_string(ReadStatus s) noexcept {
  switch (s) {
    case ReadStatus::ok:
      return "ok";
    case ReadStatus::timeout:
      return "timeout";
    case ReadStatus::bad_frame:
      return "bad frame";
    case ReadStatus::exception:
      return "exception response";
    case ReadStatus::disconnected:
      return "disconnected";
  }
  return "?";
}

std::string exception_text(int exception_code) { return modbus_strerror(MODBUS_ENOBASE + exception_code); }

ModbusClient::ModbusClient(ModbusEndpoint endpoint) : endpoint_(std::move(endpoint)) {}

ModbusClient::~ModbusClient() { close(); }

bool ModbusClient::connect(std::string& error) {
  close();
  // A new TCP connection has nothing outstanding. A serial line reopened is the same bus: an answer
  // to a read of the last opening may still come, so the line stays out of step until a marker's
  // answer says otherwise. What the server supports is learnt again.
  if (endpoint_.kind == ModbusEndpoint::Kind::tcp) in_step();
  probe_ignored_ = false;
  modbus_t* ctx = endpoint_.kind == ModbusEndpoint::Kind::tcp
                      ? modbus_new_tcp(endpoint_.host.c_str(), endpoint_.port)
                      : modbus_new_rtu(endpoint_.device.c_str(), endpoint_.baud, endpoint_.parity, endpoint_.data_bits,
                                       endpoint_.stop_bits);
  if (!ctx) {
    error = std::string("cannot create Modbus context: ") + modbus_strerror(errno);
    return false;
  }
  modbus_set_slave(ctx, endpoint_.unit_id);
  const auto to = endpoint_.response_timeout.count();
  modbus_set_response_timeout(ctx, static_cast<std::uint32_t>(to / 1000), static_cast<std::uint32_t>(to % 1000) * 1000);
  const auto byte_to = to / 2 + 1;  // a frame that stops half way counts as a timeout too
  modbus_set_byte_timeout(ctx, static_cast<std::uint32_t>(byte_to / 1000),
                          static_cast<std::uint32_t>(byte_to % 1000) * 1000);
  modbus_set_error_recovery(ctx, MODBUS_ERROR_RECOVERY_NONE);  // we classify and recover ourselves
  if (modbus_connect(ctx) != 0) {
    error = endpoint_.describe() + ": " + modbus_strerror(errno);
    modbus_free(ctx);
    return false;
  }
  ctx_ = ctx;
  return true;
}

void ModbusClient::close() noexcept {
  if (!ctx_) return;
  modbus_close(ctx_);
  modbus_free(ctx_);
  ctx_ = nullptr;
}

namespace {

ReadResult classify(int err) {
  ReadResult r;
  r.message = modbus_strerror(err);
  if (err == ETIMEDOUT) {
    r.status = ReadStatus::timeout;
  } else if (err >= EMBXILFUN && err <= EMBXGTAR) {
    r.status = ReadStatus::exception;
    r.exception_code = err - MODBUS_ENOBASE;
  } else if (err == EMBBADCRC || err == EMBBADDATA || err == EMBBADEXC || err == EMBUNKEXC || err == EMBMDATA ||
             err == EMBBADSLAVE || err == EINVAL) {
    r.status = ReadStatus::bad_frame;
  } else {
    r.status = ReadStatus::disconnected;  // ECONNRESET, EPIPE, EIO, EBADF: the link is gone
  }
  return r;
}

}  // namespace

ReadResult ModbusClient::read(RegisterFunction function, std::uint16_t address, std::uint16_t count,
                              std::span<std::uint16_t> out) noexcept {
  if (!ctx_) return {ReadStatus::disconnected, 0, "not connected"};
  if (out.size() < count) return {ReadStatus::bad_frame, 0, "output buffer too small"};
  if (count == 0 || count > 125) return {ReadStatus::bad_frame, 0, "a read asks for 1 to 125 registers"};
  if (resync_needed_) {
    ReadResult failure;
    if (!resync(function, address, count, failure)) return failure;
  }
  const int rc = function == RegisterFunction::holding ? modbus_read_registers(ctx_, address, count, out.data())
                                                       : modbus_read_input_registers(ctx_, address, count, out.data());
  if (rc == count) {
    Block& widest = widest_answered_[static_cast<std::size_t>(function)];
    if (count > widest.count) widest = {address, count};
    in_step();
    return {};
  }
  if (endpoint_.kind == ModbusEndpoint::Kind::rtu) {
    resync_needed_ = true;
    unanswered_counts_[static_cast<std::size_t>(function)].set(count);
  }
  if (rc >= 0) return {ReadStatus::bad_frame, 0, "short answer: " + std::to_string(rc) + " registers"};
  const ReadResult r = classify(errno);
  if (r.status == ReadStatus::exception) in_step();  // an answer: the line is in step
  return r;
}

namespace {
constexpr std::uint8_t report_server_id = 0x11;
}  // namespace

bool ModbusClient::resync(RegisterFunction function, std::uint16_t address, std::uint16_t count,
                          ReadResult& failure) noexcept {
  // The smallest count no unanswered read of this function asked for, within registers the server
  // has: the coming read's, or the widest block it answered on this line; 0: none.
  const Block& widest = widest_answered_[static_cast<std::size_t>(function)];
  std::uint16_t marker = 0;
  for (std::uint16_t m = 1; m <= std::max(count, widest.count) && marker == 0; ++m) {
    if (!unanswered_counts_[static_cast<std::size_t>(function)].test(m)) marker = m;
  }
  if (marker > count) address = widest.address;
  if (!probe_ignored_ && (!silent_probe_ || marker == 0)) {
    const ProbeOutcome probed = resync_by_probe(failure);
    if (probed != ProbeOutcome::unproven) return probed == ProbeOutcome::in_step;
    if (marker == 0) {  // nothing better to go by
      in_step();
      return true;
    }
    probes_unanswered_ = 0;  // frames were heard: the marker shows nothing about FC 17
  }
  if (marker > 0) return resync_by_read(function, address, marker, failure);
  // Every count up to this read's is unanswered on a server that ignores FC 17: nothing tells a late
  // answer apart. Flushing only (a rare case: a failed 1-register read, say).
  discard_input();
  in_step();
  return true;
}

ModbusClient::ProbeOutcome ModbusClient::resync_by_probe(ReadResult& failure) noexcept {
  const std::uint8_t probe[] = {static_cast<std::uint8_t>(endpoint_.unit_id), report_server_id};
  discard_input();
  if (modbus_send_raw_request(ctx_, probe, sizeof probe) < 0) {
    failure = classify(errno);
    return ProbeOutcome::failed;
  }
  ++probes_unanswered_;
  // Frames come in order: the failed requests' late answers first, then the probes' answers (which
  // can never pass for a register read, however late: a wrong function code). In step once every
  // probe sent since the line was last in step is answered. Frames followed by a whole response
  // timeout of silence prove nothing (earlier probes lost on a dead line, a probe's answer taken by a
  // failed read or damaged; or a server still busy with a late request): unproven.
  std::uint8_t frame[MODBUS_MAX_ADU_LENGTH];
  bool heard = false;
  for (int frames = 0; frames < 64; ++frames) {
    const int n = modbus_receive_confirmation(ctx_, frame);
    if (n > 1 && (frame[1] & 0x7f) == report_server_id) {
      heard = true;
      if (--probes_unanswered_ > 0) continue;  // an earlier probe's answer
      in_step();
      return ProbeOutcome::in_step;
    }
    if (n >= 0) {  // a register answer, or (0) a frame for another unit or a cut tail: stale
      heard = true;
      ++stale_answers_;
      continue;
    }
    const int err = errno;
    if (err == ETIMEDOUT) {
      if (heard) return ProbeOutcome::unproven;
      // Nothing at all: a failed read (a server gone away is declared lost as soon as without the
      // probe). The server may be busy with a request it will still answer (after it, this probe), or
      // may ignore FC 17: the next read is preceded by a marker read instead.
      silent_probe_ = true;
      failure = classify(err);
      return ProbeOutcome::failed;
    }
    const ReadResult r = classify(err);
    if (r.status == ReadStatus::disconnected) {
      failure = r;
      return ProbeOutcome::failed;
    }
    heard = true;
    ++stale_answers_;  // a damaged frame: drop what is left of it and go on
    discard_input();
  }
  failure = {ReadStatus::bad_frame, 0, "64 frames while waiting for the answer to Report Server ID"};
  return ProbeOutcome::failed;  // still out of step: the next read probes again
}

bool ModbusClient::resync_by_read(RegisterFunction function, std::uint16_t address, std::uint16_t marker,
                                  ReadResult& failure) noexcept {
  const std::uint8_t code = function == RegisterFunction::holding ? 0x03 : 0x04;
  const std::uint8_t request[] = {
      static_cast<std::uint8_t>(endpoint_.unit_id), code, static_cast<std::uint8_t>(address >> 8),
      static_cast<std::uint8_t>(address & 0xff),    0,    static_cast<std::uint8_t>(marker)};
  discard_input();
  if (modbus_send_raw_request(ctx_, request, sizeof request) < 0) {
    failure = classify(errno);
    return false;
  }
  unanswered_counts_[static_cast<std::size_t>(function)].set(marker);  // until its answer comes
  // In order again: late register answers (another byte count), the answers of probes sent before
  // (if the server answers FC 17 at all), then the marker's. Unlike a probe's, its answer cannot have
  // been taken by an earlier read: silence means it is still to come, or the server is gone.
  std::uint8_t frame[MODBUS_MAX_ADU_LENGTH];
  for (int frames = 0; frames < 64; ++frames) {
    const int n = modbus_receive_confirmation(ctx_, frame);
    if (n > 1 && (frame[1] & 0x7f) == report_server_id) {  // a late probe's answer: FC 17 is answered
      silent_probe_ = false;
      if (probes_unanswered_ > 0) --probes_unanswered_;
      continue;
    }
    if (n == 5 + 2 * marker && frame[1] == code && frame[2] == 2 * marker) {
      // Probes sent before it and still unanswered were ignored.
      if (probes_unanswered_ > 0) probe_ignored_ = true;
      in_step();
      return true;
    }
    if (n >= 0) {  // another register answer (a late one), an exception, another unit's frame: stale
      // An exception may be the marker's own: registers no longer there (another device on the
      // line); the next marker keeps within the coming read's.
      if (n > 2 && frame[1] == (code | 0x80)) widest_answered_[static_cast<std::size_t>(function)] = {};
      ++stale_answers_;
      continue;
    }
    const int err = errno;
    const ReadResult r = classify(err);
    if (err == ETIMEDOUT || r.status == ReadStatus::disconnected) {
      failure = r;
      return false;  // still out of step: the next read sends another marker
    }
    ++stale_answers_;  // a damaged frame: drop what is left of it and go on
    discard_input();
  }
  failure = {ReadStatus::bad_frame, 0, "64 frames while waiting for the answer to a marker read"};
  return false;
}

void ModbusClient::in_step() noexcept {
  resync_needed_ = false;
  silent_probe_ = false;
  probes_unanswered_ = 0;
  for (auto& counts : unanswered_counts_) counts.reset();
}

void ModbusClient::flush() noexcept {
  if (ctx_) discard_input();
}

void ModbusClient::discard_input() noexcept {
  // libmodbus's RTU flush is tcflush(TCIOFLUSH): it would also drop requests written but not yet
  // sent (a probe or a marker the line never carries, or one cut short), which then never answer.
  if (endpoint_.kind == ModbusEndpoint::Kind::rtu) {
    ::tcflush(modbus_get_socket(ctx_), TCIFLUSH);
  } else {
    modbus_flush(ctx_);
  }
}

}  // namespace guideway::drivers::modbus
