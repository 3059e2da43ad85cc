// Modbus RTU on a thread of the line's own (rtu_line.hpp): libmodbus's blocking reads off the I/O loop, answered
// through an eventfd.
#include "drivers/modbus/rtu_line.hpp"

#include <pthread.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>
#include <utility>

#include "core/mono_clock.hpp"

namespace guideway::drivers::modbus {

RtuLine::RtuLine(ModbusEndpoint endpoint) : client_(std::move(endpoint)) {
  event_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (event_fd_ < 0) throw std::system_error(errno, std::generic_category(), "eventfd");
}

RtuLine::~RtuLine() {
  close();
  ::close(event_fd_);
}

bool RtuLine::open(std::string& error) {
  close();
  if (!client_.connect(error)) return false;
  std::uint64_t n = 0;
  while (::read(event_fd_, &n, sizeof n) > 0) {
  }  // a ring left by an earlier opening
  {
    const std::lock_guard lock(mutex_);
    pending_ = done_ = stopping_ = false;
  }
  thread_ = std::thread([this] { serve(); });
  ::pthread_setname_np(thread_.native_handle(), "gw-rtu");
  return true;
}

void RtuLine::close() noexcept {
  if (thread_.joinable()) {
    {
      const std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_all();
    thread_.join();  // after the batch under way: its reads must not outlive the caller's wait
  }
  client_.close();
}

void RtuLine::ask(std::span<RegisterRead> reads, bool flush_first) {
  {
    const std::lock_guard lock(mutex_);
    batch_ = reads;
    flush_first_ = flush_first;
    pending_ = true;
    done_ = false;
  }
  cv_.notify_all();
}

bool RtuLine::answered() {
  std::uint64_t n = 0;
  while (::read(event_fd_, &n, sizeof n) > 0) {
  }
  const std::lock_guard lock(mutex_);
  if (!done_) return false;
  done_ = false;
  stale_answers_ = stale_seen_;
  return true;
}

void RtuLine::wait() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [this] { return !pending_ || !thread_.joinable(); });
}

void RtuLine::serve() {
  std::unique_lock lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return stopping_ || pending_; });
    if (!pending_) return;  // stopping, nothing under way
    const std::span<RegisterRead> reads = batch_;
    const bool flush_first = flush_first_;
    lock.unlock();
    read_batch(reads, flush_first);
    lock.lock();
    stale_seen_ = client_.stale_answers();
    pending_ = false;
    done_ = true;
    cv_.notify_all();
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t put = ::write(event_fd_, &one, sizeof one);
    if (stopping_) return;
  }
}

void RtuLine::read_batch(std::span<RegisterRead> reads, bool flush_first) noexcept {
  if (flush_first) client_.flush();  // stray or late answers must not be taken for this batch's
  for (std::size_t i = 0; i < reads.size(); ++i) {
    RegisterRead& x = reads[i];
    const ReadStatus before = i > 0 ? reads[i - 1].result.status : ReadStatus::ok;
    if (before != ReadStatus::ok && before != ReadStatus::exception) {
      x.result = reads[i - 1].result;  // the line failed: the rest would fail the same way, one timeout each
      x.t_answer_ns = reads[i - 1].t_answer_ns;
      continue;
    }
    x.result = client_.read(x.function, x.address, x.count, x.block);
    x.t_answer_ns = mono_now_ns();
  }
}

}  // namespace guideway::drivers::modbus
