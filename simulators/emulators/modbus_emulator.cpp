// An emulated gauge amplifier (modbus_emulator.hpp): a real libmodbus server on TCP or on an RTU pseudo-terminal,
// faults injected.
#include "simulators/emulators/modbus_emulator.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <numbers>
#include <optional>
#include <sstream>
#include <thread>

#include "core/sample.hpp"

namespace guideway::simulators::emulators {

namespace {

modbus_t* as_ctx(void* p) { return static_cast<modbus_t*>(p); }
modbus_mapping_t* as_mapping(void* p) { return static_cast<modbus_mapping_t*>(p); }

std::uint16_t crc16_modbus(const std::uint8_t* data, std::size_t n) {
  std::uint16_t crc = 0xffff;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ data[i]);
    for (int b = 0; b < 8; ++b) crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xa001) : crc >> 1;
  }
  return crc;
}

void write_all(int fd, const std::uint8_t* data, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return;
    data += w;
    n -= static_cast<std::size_t>(w);
  }
}

int open_pty(std::string& slave_path, int& slave_fd) {
  const int master = posix_openpt(O_RDWR | O_NOCTTY);
  if (master < 0) return -1;
  if (grantpt(master) != 0 || unlockpt(master) != 0) {
    ::close(master);
    return -1;
  }
  slave_path = ptsname(master);
  // Hold the slave open (so the master never reads EIO while the client reconnects) and make it raw:
  // no echo, no line editing, 8 bits through.
  slave_fd = ::open(slave_path.c_str(), O_RDWR | O_NOCTTY);
  if (slave_fd < 0) {
    ::close(master);
    return -1;
  }
  termios tio{};
  tcgetattr(slave_fd, &tio);
  cfmakeraw(&tio);
  tcsetattr(slave_fd, TCSANOW, &tio);
  return master;
}

void close_fd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

}  // namespace

MicrometerSource runout_source(double rpm, double eccentricity_m, double second_harmonic_m) {
  return [=](double t_s) {
    const double angle = 2.0 * std::numbers::pi * rpm / 60.0 * t_s;
    return MicrometerPoint{eccentricity_m * std::cos(angle) + second_harmonic_m * std::cos(2.0 * angle + 0.4)};
  };
}

std::string_view to_string(ModbusFault f) noexcept {
  switch (f) {
    case ModbusFault::exception:
      return "exception";
    case ModbusFault::stall:
      return "stall";
    case ModbusFault::garbage:
      return "garbage";
    case ModbusFault::truncate:
      return "truncate";
    case ModbusFault::bad_crc:
      return "bad_crc";
    case ModbusFault::burst:
      return "burst";
    case ModbusFault::late:
      return "late";
  }
  return "?";
}

bool modbus_fault_from_string(std::string_view s, ModbusFault& out) noexcept {
  for (ModbusFault f : {ModbusFault::exception, ModbusFault::stall, ModbusFault::garbage, ModbusFault::truncate,
                        ModbusFault::bad_crc, ModbusFault::burst, ModbusFault::late}) {
    if (to_string(f) == s) {
      out = f;
      return true;
    }
  }
  return false;
}

MicrometerEmulator::MicrometerEmulator(Options options) : options_(std::move(options)) {
  const drivers::modbus::RegisterMap& m = options_.map;
  std::uint32_t start = m.block_start();
  std::uint32_t end = start + m.block_count();
  if (const auto& ring = options_.ring) {
    start = std::min({start, std::uint32_t{ring->counter_address}, std::uint32_t{ring->ring_address}});
    end = std::max({end, ring->counter_address + 2u, ring->ring_address + ring->ring_registers()});
  }
  mapping_start_ = start;
  mapping_ = modbus_mapping_new_start_address(0, 0, 0, 0, start, end - start, start, end - start);
}

void MicrometerEmulator::restart_ring(std::chrono::milliseconds ago) { ring_restart_ago_ns_ = ago.count() * 1'000'000; }

std::int64_t MicrometerEmulator::ring_start_ns() const noexcept {
  std::lock_guard lock(mutex_);
  return std::chrono::duration_cast<std::chrono::nanoseconds>(ring_t0_.time_since_epoch()).count();
}

void MicrometerEmulator::set_register(std::uint32_t address, std::uint16_t value) {
  modbus_mapping_t* mapping = as_mapping(mapping_);
  mapping->tab_registers[address - mapping_start_] = value;
  mapping->tab_input_registers[address - mapping_start_] = value;
}

void MicrometerEmulator::fill_ring(double t_s) {
  const drivers::modbus::SampleRingMap& ring = *options_.ring;
  // Filled when asked, not on a timer: what a request sees is what a device sampling all along shows.
  const auto taken = static_cast<std::uint64_t>(std::floor(std::max(0.0, t_s) * ring.sample_rate_hz));
  const std::uint64_t from = std::max(ring_taken_, taken > ring.ring_samples ? taken - ring.ring_samples : 0);
  const std::uint32_t rec = ring.record_registers();
  for (std::uint64_t k = from; k < taken; ++k) {
    const MicrometerPoint p = options_.source(static_cast<double>(k) / ring.sample_rate_hz);
    std::uint16_t status = 0;
    if (p.out_of_range) status |= ring.record.out_of_range_mask;
    if (p.probe_missing) status |= ring.record.probe_missing_mask;
    const std::vector<std::uint16_t> regs = drivers::modbus::encode_registers(ring.record, p.value_m, status);
    const std::uint32_t slot = drivers::modbus::ring_slot(ring, options_.ring_counter_start + k);
    for (std::uint32_t i = 0; i < rec; ++i) set_register(ring.ring_address + slot * rec + i, regs[i]);
  }
  ring_taken_ = std::max(ring_taken_, taken);
  const auto counter =
      drivers::modbus::encode_counter(ring, static_cast<std::uint32_t>(options_.ring_counter_start + ring_taken_));
  set_register(ring.counter_address, counter[0]);
  set_register(ring.counter_address + 1u, counter[1]);
}

MicrometerEmulator::~MicrometerEmulator() {
  stop();
  if (mapping_) modbus_mapping_free(as_mapping(mapping_));
}

int MicrometerEmulator::start_tcp(const std::string& host, int port, std::string& error) {
  if (running_) {
    error = "already running";
    return -1;
  }
  host_ = host;
  ctx_ = modbus_new_tcp(host.c_str(), port);
  if (!ctx_ || !mapping_) {
    error = std::string("libmodbus: ") + modbus_strerror(errno);
    return -1;
  }
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  const int one = 1;
  setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    error = "not an IPv4 address: " + host;
    close_fd(listen_fd_);
    return -1;
  }
  if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 || ::listen(listen_fd_, 4) != 0) {
    error = host + ":" + std::to_string(port) + ": " + std::strerror(errno);
    close_fd(listen_fd_);
    return -1;
  }
  socklen_t len = sizeof(addr);
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  const int actual = ntohs(addr.sin_port);
  t0_ = std::chrono::steady_clock::now();
  ring_t0_ = t0_;
  running_ = true;
  server_thread_ = std::thread([this, actual] { tcp_loop(actual); });
  return actual;
}

std::string MicrometerEmulator::start_rtu(int baud, char parity, int data_bits, int stop_bits, std::string& error) {
  if (running_) {
    error = "already running";
    return {};
  }
  std::string server_path, client_path;
  pty_server_master_ = open_pty(server_path, pty_server_slave_);
  pty_client_master_ = open_pty(client_path, pty_client_slave_);
  if (pty_server_master_ < 0 || pty_client_master_ < 0) {
    error = std::string("cannot create pseudo-terminals: ") + std::strerror(errno);
    stop();
    return {};
  }
  ctx_ = modbus_new_rtu(server_path.c_str(), baud, parity, data_bits, stop_bits);
  if (!ctx_ || !mapping_) {
    error = std::string("libmodbus: ") + modbus_strerror(errno);
    stop();
    return {};
  }
  modbus_set_slave(as_ctx(ctx_), options_.unit_id);
  if (modbus_connect(as_ctx(ctx_)) != 0) {
    error = server_path + ": " + modbus_strerror(errno);
    stop();
    return {};
  }
  t0_ = std::chrono::steady_clock::now();
  ring_t0_ = t0_;
  running_ = true;
  server_thread_ = std::thread([this] { rtu_loop(); });
  bridge_thread_ = std::thread([this] { bridge_loop(); });
  return client_path;
}

void MicrometerEmulator::stop() {
  running_ = false;
  if (server_thread_.joinable()) server_thread_.join();
  if (bridge_thread_.joinable()) bridge_thread_.join();
  if (ctx_) {
    modbus_close(as_ctx(ctx_));
    modbus_free(as_ctx(ctx_));
    ctx_ = nullptr;
  }
  close_fd(listen_fd_);
  close_fd(pty_server_master_);
  close_fd(pty_client_master_);
  close_fd(pty_server_slave_);
  close_fd(pty_client_slave_);
}

void MicrometerEmulator::inject(ModbusFault f, int count) {
  std::lock_guard lock(mutex_);
  for (int i = 0; i < count; ++i) pending_.push_back(f);
}

void MicrometerEmulator::disconnect_for(std::chrono::milliseconds d) {
  std::lock_guard lock(mutex_);
  down_until_ = std::chrono::steady_clock::now() + d;
  drop_connection_ = true;
}

std::vector<ServedReading> MicrometerEmulator::served() const {
  std::lock_guard lock(mutex_);
  return served_;
}

void MicrometerEmulator::record_counter(std::uint16_t start, std::uint16_t count) {
  const auto& ring = options_.ring;
  if (!ring || start > ring->counter_address || start + count < ring->counter_address + 2) return;
  std::lock_guard lock(mutex_);
  if (served_counters_.size() == max_served_counters) served_counters_.pop_front();
  served_counters_.push_back(ring_taken_);
}

std::vector<std::uint64_t> MicrometerEmulator::served_counters() const {
  std::lock_guard lock(mutex_);
  return {served_counters_.begin(), served_counters_.end()};
}

bool MicrometerEmulator::line_down() const {
  std::lock_guard lock(mutex_);
  return std::chrono::steady_clock::now() < down_until_;
}

void MicrometerEmulator::tcp_loop(int port) {
  modbus_t* ctx = as_ctx(ctx_);
  int client = -1;
  std::uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
  while (running_) {
    bool drop = false;
    {
      std::lock_guard lock(mutex_);
      drop = drop_connection_;
      drop_connection_ = false;
    }
    if (drop) {  // unplug: close the connection and stop listening until the line is back
      close_fd(client);
      modbus_set_socket(ctx, -1);
      close_fd(listen_fd_);
    }
    if (line_down()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    if (listen_fd_ < 0) {
      listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
      const int one = 1;
      setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
      sockaddr_in addr{};
      addr.sin_family = AF_INET;
      addr.sin_port = htons(static_cast<std::uint16_t>(port));
      inet_pton(AF_INET, host_.c_str(), &addr.sin_addr);
      if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 || ::listen(listen_fd_, 4) != 0) {
        close_fd(listen_fd_);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
    }
    pollfd p{client >= 0 ? client : listen_fd_, POLLIN, 0};
    if (::poll(&p, 1, 20) <= 0) continue;
    if (client < 0) {
      client = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (client >= 0) {
        const int one = 1;  // answers leave at once, as from a real device (no Nagle delay between frames)
        setsockopt(client, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
        modbus_set_socket(ctx, client);
        connections_.fetch_add(1);
      }
      continue;
    }
    const int rc = modbus_receive(ctx, query);
    if (rc < 0) {  // peer closed or sent something unparseable: drop the connection
      close_fd(client);
      modbus_set_socket(ctx, -1);
      continue;
    }
    if (rc > 0) handle(query, rc, client, false);
  }
  close_fd(client);
  modbus_set_socket(ctx, -1);
}

void MicrometerEmulator::rtu_loop() {
  modbus_t* ctx = as_ctx(ctx_);
  std::uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
  const int fd = modbus_get_socket(ctx);
  connections_.fetch_add(1);
  while (running_) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 20) <= 0) continue;
    const int rc = modbus_receive(ctx, query);
    if (rc > 0) {
      handle(query, rc, fd, true);
    } else if (rc < 0) {
      modbus_flush(ctx);  // a broken request (CRC, truncated): discard, as a real amplifier does
    }
  }
}

void MicrometerEmulator::bridge_loop() {
  std::uint8_t buf[512];
  while (running_) {
    pollfd p[2] = {{pty_server_master_, POLLIN, 0}, {pty_client_master_, POLLIN, 0}};
    if (::poll(p, 2, 20) <= 0) continue;
    for (int i = 0; i < 2; ++i) {
      if (!(p[i].revents & POLLIN)) continue;
      const ssize_t n = ::read(p[i].fd, buf, sizeof(buf));
      if (n <= 0) continue;
      if (line_down()) continue;  // unplugged line: bytes go nowhere
      write_all(i == 0 ? pty_client_master_ : pty_server_master_, buf, static_cast<std::size_t>(n));
    }
  }
}

void MicrometerEmulator::handle(const std::uint8_t* query, int length, int fd, bool rtu) {
  modbus_t* ctx = as_ctx(ctx_);
  modbus_mapping_t* mapping = as_mapping(mapping_);
  const int hl = modbus_get_header_length(ctx);
  const std::uint64_t request = requests_.fetch_add(1);
  const double t_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  const MicrometerPoint point = options_.source ? options_.source(t_s) : MicrometerPoint{};
  const drivers::modbus::RegisterMap& map = options_.map;
  std::uint16_t status = 0;
  if (point.out_of_range) status |= map.out_of_range_mask;
  if (point.probe_missing) status |= map.probe_missing_mask;
  const std::vector<std::uint16_t> block = drivers::modbus::encode_registers(map, point.value_m, status);
  for (std::uint32_t i = 0; i < block.size(); ++i) set_register(map.block_start() + i, block[i]);
  if (options_.ring && options_.source) {
    const auto now = std::chrono::steady_clock::now();
    if (const std::int64_t ago = ring_restart_ago_ns_.exchange(-1); ago >= 0) {
      std::lock_guard lock(mutex_);
      ring_t0_ = now - std::chrono::nanoseconds(ago);  // the amplifier restarted: counter from 0, old slots stale
      ring_taken_ = 0;
      options_.ring_counter_start = 0;
    }
    std::chrono::steady_clock::time_point ring_t0;
    {
      std::lock_guard lock(mutex_);
      ring_t0 = ring_t0_;
    }
    fill_ring(std::chrono::duration<double>(now - ring_t0).count());
  }
  std::optional<ModbusFault> fault;
  if (line_down()) return;  // RTU: the bridge drops the answer anyway; TCP closes before reaching here
  const int fc = length > hl ? query[hl] : 0;
  const bool register_read = (fc == 3 || fc == 4) && length >= hl + 5;
  if (fc == 0x11 && !options_.answers_report_server_id) return;
  if (register_read) {  // faults are for register reads: other requests (a master's FC 17) pass by them
    std::lock_guard lock(mutex_);
    if (!pending_.empty()) {
      fault = pending_.front();
      pending_.pop_front();
    }
  }
  auto record = [&] {
    const drivers::modbus::Reading r = drivers::modbus::decode_registers(map, block);
    const std::uint16_t start = static_cast<std::uint16_t>((query[hl + 1] << 8) | query[hl + 2]);
    const std::uint16_t count = static_cast<std::uint16_t>((query[hl + 3] << 8) | query[hl + 4]);
    if (start != map.block_start() || count != map.block_count()) return;  // not the driver's block read
    std::lock_guard lock(mutex_);
    served_.push_back({request, r.value_m, r.flags});
  };
  if (!fault || !register_read) {
    if (modbus_reply(ctx, query, length, mapping) > 0 && register_read) {
      record();
      record_counter(static_cast<std::uint16_t>((query[hl + 1] << 8) | query[hl + 2]),
                     static_cast<std::uint16_t>((query[hl + 3] << 8) | query[hl + 4]));
    }
    return;
  }
  switch (*fault) {
    case ModbusFault::exception:
      modbus_reply_exception(ctx, query, MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY);
      return;
    case ModbusFault::stall:
      return;
    case ModbusFault::late:
      // The right answer after the client gave up on it: not served (the driver must not take it).
      std::this_thread::sleep_for(options_.late_answer_ms);
      modbus_reply(ctx, query, length, mapping);
      return;
    default:
      break;
  }
  // Build the answer by hand, so it can be damaged byte by byte.
  const std::uint16_t start = static_cast<std::uint16_t>((query[hl + 1] << 8) | query[hl + 2]);
  const std::uint16_t count = static_cast<std::uint16_t>((query[hl + 3] << 8) | query[hl + 4]);
  const std::uint16_t* table = fc == 3 ? mapping->tab_registers : mapping->tab_input_registers;
  const int table_start = fc == 3 ? mapping->start_registers : mapping->start_input_registers;
  const int table_size = fc == 3 ? mapping->nb_registers : mapping->nb_input_registers;
  if (count == 0 || count > 125 || start < table_start || start + count > table_start + table_size) {
    modbus_reply(ctx, query, length, mapping);  // not ours to damage: the normal exception answer
    return;
  }
  std::vector<std::uint8_t> frame;
  if (rtu) {
    frame.push_back(query[0]);
  } else {
    frame.insert(frame.end(), {query[0], query[1], 0, 0, 0, 0, query[6]});
  }
  frame.push_back(static_cast<std::uint8_t>(fc));
  frame.push_back(static_cast<std::uint8_t>(count * 2));
  for (int i = 0; i < count; ++i) {
    const std::uint16_t v = table[start - table_start + i];
    frame.push_back(static_cast<std::uint8_t>(v >> 8));
    frame.push_back(static_cast<std::uint8_t>(v & 0xff));
  }
  if (rtu) {
    const std::uint16_t crc = crc16_modbus(frame.data(), frame.size());
    frame.push_back(static_cast<std::uint8_t>(crc & 0xff));
    frame.push_back(static_cast<std::uint8_t>(crc >> 8));
  } else {
    const std::size_t pdu = frame.size() - 6;
    frame[4] = static_cast<std::uint8_t>(pdu >> 8);
    frame[5] = static_cast<std::uint8_t>(pdu & 0xff);
  }
  switch (*fault) {
    case ModbusFault::garbage:
      for (auto& b : frame) {
        rng_ ^= rng_ << 13;
        rng_ ^= rng_ >> 17;
        rng_ ^= rng_ << 5;
        b = static_cast<std::uint8_t>(rng_);
      }
      write_all(fd, frame.data(), frame.size());
      break;
    case ModbusFault::truncate:
      write_all(fd, frame.data(), frame.size() / 2);
      break;
    case ModbusFault::bad_crc:
      if (rtu) {
        frame.back() ^= 0x5a;
      } else {
        frame[1] ^= 0x5a;  // TCP has no CRC: a damaged transaction id is what the client can detect
      }
      write_all(fd, frame.data(), frame.size());
      break;
    case ModbusFault::burst: {
      // Back to back in one write, as on the wire: the copies arrive together with the answer.
      std::vector<std::uint8_t> three;
      for (int i = 0; i < 3; ++i) three.insert(three.end(), frame.begin(), frame.end());
      write_all(fd, three.data(), three.size());
      record();
      break;
    }
    default:
      break;
  }
}

bool apply_micrometer_command(MicrometerEmulator& emulator, const std::string& line, std::string& message) {
  std::istringstream in(line);
  std::string word, name;
  in >> word;
  if (word == "fault") {
    int count = 1;
    in >> name;
    if (!(in >> count)) count = 1;
    ModbusFault f{};
    if (!modbus_fault_from_string(name, f) || count < 1) {
      message = "unknown fault \"" + name + "\" (exception, stall, garbage, truncate, bad_crc, burst, late)";
      return false;
    }
    emulator.inject(f, count);
    message = "ok fault " + name + " " + std::to_string(count);
    return true;
  }
  if (word == "disconnect") {
    long ms = 0;
    if (!(in >> ms) || ms < 0) {
      message = "usage: disconnect <ms>";
      return false;
    }
    emulator.disconnect_for(std::chrono::milliseconds(ms));
    message = "ok disconnect " + std::to_string(ms);
    return true;
  }
  message = "unknown command \"" + word + "\" (fault <name> [count], disconnect <ms>)";
  return false;
}

}  // namespace guideway::simulators::emulators
