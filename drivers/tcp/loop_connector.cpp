// One TCP connection attempt on an I/O loop that never blocks it (loop_connector.hpp): resolve off the loop, try each
// address.
#include "drivers/tcp/loop_connector.hpp"

#include <sys/epoll.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/mono_clock.hpp"

namespace guideway::drivers::tcp {

namespace {
constexpr std::int64_t resolver_look_ns = 5'000'000;  // a name being looked up: look again this soon
}

void LoopConnector::attach(IoLoop& loop, Connected connected, Failed failed) {
  io_ = &loop;
  connected_ = std::move(connected);
  failed_ = std::move(failed);
  timer_ = loop.add_timer([this] { on_timer(); });
}

void LoopConnector::detach() {
  if (io_ == nullptr) return;
  cancel();
  io_->remove_timer(timer_);
  io_ = nullptr;
}

void LoopConnector::start(const std::string& host, int port, std::string label, std::chrono::nanoseconds timeout) {
  cancel();
  label_ = std::move(label);
  timeout_ = timeout;
  addresses_.clear();
  next_ = 0;
  error_.clear();
  step_ = Step::resolving;
  resolver_.start(host, port);
  on_timer();  // an address is resolved at once; a name is looked up off the loop, then looked at
}

void LoopConnector::cancel() {
  resolver_.cancel();
  close_socket();
  step_ = Step::idle;
}

void LoopConnector::close_socket() {
  if (fd_ < 0) return;
  io_->unwatch(fd_);
  ::close(fd_);
  fd_ = -1;
}

void LoopConnector::on_timer() {
  const std::int64_t now = mono_now_ns();
  switch (step_) {
    case Step::idle:
      return;
    case Step::resolving: {
      std::string error;
      if (!resolver_.done(addresses_, error)) {
        io_->arm(timer_, now + resolver_look_ns);
        return;
      }
      if (addresses_.empty()) {
        fail(label_ + ": " + error);
        return;
      }
      next_address();
      return;
    }
    case Step::connecting:
      if (now < deadline_ns_) {
        io_->arm(timer_, deadline_ns_);
        return;
      }
      close_socket();
      error_ = label_ + ": " + std::strerror(ETIMEDOUT);
      next_address();
      return;
  }
}

void LoopConnector::next_address() {
  while (next_ < addresses_.size()) {
    bool done = false;
    std::string error;
    fd_ = start_connect(addresses_[next_++], done, error);
    if (fd_ < 0) {
      error_ = label_ + ": " + error;
      continue;
    }
    if (done) {
      succeed();
      return;
    }
    step_ = Step::connecting;
    io_->watch(fd_, EPOLLOUT, [this](std::uint32_t) { on_writable(); });
    deadline_ns_ = mono_now_ns() + timeout_.count();
    io_->arm(timer_, deadline_ns_);
    return;
  }
  fail(error_.empty() ? label_ + ": no address" : error_);
}

void LoopConnector::on_writable() {
  const int err = connect_error(fd_);
  if (err == 0) {
    io_->unwatch(fd_);
    succeed();
    return;
  }
  close_socket();
  error_ = label_ + ": " + std::strerror(err);
  next_address();
}

void LoopConnector::succeed() {
  const int fd = fd_;
  fd_ = -1;
  step_ = Step::idle;
  connected_(fd);
}

void LoopConnector::fail(const std::string& error) {
  step_ = Step::idle;
  failed_(error);
}

}  // namespace guideway::drivers::tcp
