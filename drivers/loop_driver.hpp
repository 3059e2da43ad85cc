#pragma once
// The skeleton of every loop-driven driver (drivers/io_loop.hpp). It owns what each such driver used
// to write again: the loop's timer and hooks, the link (open, the back-off between failed opens, up,
// ended) and the read schedule ("rest read_period while data flows, read at the other devices'
// passes, settle on an empty read"). A driver derived from it is its protocol: it opens its
// transport, reads what is queued (read_some: taken / more / ended), reacts to its link coming up and
// going down, and does its own timed work (service: requests, SYNCs, protocol timeouts). The contract,
// hook by hook, is in docs/plugins.md ("A built-in loop-driven driver").
// Thread safety: as drivers::Driver. Everything below runs on the loop's thread, attach() to detach().

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "core/backoff.hpp"
#include "drivers/driver.hpp"
#include "drivers/io_loop.hpp"
#include "drivers/tcp/loop_connector.hpp"

namespace guideway::drivers {

// What one read of the transport did.
struct ReadOutcome {
  std::size_t taken = 0;  // what it consumed (bytes, frames, answers); 0: nothing was queued
  bool more = false;      // it stopped before the transport was empty (a flood): the rest at the next pass
  std::string ended;      // set: the link ended (closed by the peer, failed), and why
};

// When the skeleton reads the transport.
enum class ReadSchedule {
  per_arrival,  // the transport's readiness wakes the driver; every arrival is read at once
  // Read, then rest read_period while data flows (what arrives meanwhile waits in the transport,
  // keeping its kernel receive time where it has one); while resting, read at every other pass of the
  // loop (devices fall into step and share one wake-up per period); a rest that ends with an empty
  // read goes on while another device found data in that pass, else the next arrival wakes the driver.
  rest,
  // No readiness interest (hang-up and errors still end the link): the driver reads in service()
  // with read_queued(), at times of its own (a SYNC producer reading the last cycle at the next SYNC).
  paced,
};

// How a loop-driven driver retries its link, as its [[device]] table says (read_reconnect).
struct Reconnect {
  Backoff backoff{0.1, 5.0};  // between failed opens; back to its first wait after a link that gave samples
  // The table's keys that carry an old name, each said in words: the skeleton posts every one as a
  // `deprecated_key` event (a warning; the daemon logs it) when the device is made.
  std::vector<std::string> deprecated;
};

// The link's back-off keys of a [[device]] table, the same for every loop-driven driver
// (docs/configuration.md, "[[device]]"): `reconnect_min_ms`, the first wait after a failed open or a
// lost link, doubling up to `reconnect_max_ms`; the driver's defaults when they are left out. The
// names of older configurations, `backoff_initial_ms` and `backoff_max_ms`, are read in their place,
// each with a line in `deprecated`. Throws ConfigError naming file, line and key for a key given
// under both names, a value out of range, or a ceiling below the first wait.
Reconnect read_reconnect(const TableReader& table, std::chrono::milliseconds default_min,
                         std::chrono::milliseconds default_max);

struct LoopPolicy {
  Reconnect reconnect;              // the back-off between failed opens (and the old key names to warn of)
  bool unreached_is_error = false;  // an open that fails before the device was ever reached: `error` (else `lost`)
  ReadSchedule schedule = ReadSchedule::rest;  // at every link up (the driver may change it: set_schedule)
  std::int64_t read_period_ns = default_read_period_us * 1000;  // the rest; 0: the rest schedule reads per arrival
  // Alone on the loop with data further apart than a period, a rest only adds a wake-up that finds
  // nothing: after a rest that ended with nothing read anywhere the driver reads per arrival, until
  // another device makes the loop pass by.
  bool alone_reads_per_arrival = true;
  std::int64_t silence_ns = 0;  // nothing read for this long: on_silence() (once per silent period); 0: never
  // The longest the device goes without a sample while it works (Driver::set_sample_bound): `streaming`
  // is shown only while samples arrive within it. 0: no such rule.
  std::int64_t sample_bound_ns = 0;
};

class LoopDriver : public Driver {
 public:
  [[nodiscard]] bool loop_driven() const noexcept override { return true; }

 protected:
  LoopDriver(std::string name, std::string driver, std::vector<ChannelInfo> channels, std::size_t ring_capacity,
             LoopPolicy policy);

  // ---- What a driver implements (all on the loop's thread).
  // Opens the transport without blocking: link_up(fd) when it is open (now or later), link_failed(why)
  // when it could not be; connect_tcp() does either for a TCP peer.
  virtual void open() = 0;
  // Reads what the transport holds, without waiting, and parses and publishes it. At most a bounded
  // amount per call (set `more` when some was left). `at_others_pass`: read at another device's pass
  // during a rest. A driver may end the link from here (end_link) instead of returning `ended`.
  virtual ReadOutcome read_some(bool at_others_pass) = 0;
  // A new link (the protocol's state starts afresh; a request may be sent). The state is already
  // `streaming` (shown as `connecting` until the first sample: Driver::set_sample_bound).
  virtual void on_link_up(std::int64_t now_ns) { (void)now_ns; }
  // The link ends (or the device stops): publish what the parser holds, close the driver's transport.
  // The descriptor is no longer watched.
  virtual void on_link_down() {}
  // The driver's own timed work (requests, SYNCs, protocol timeouts), after every read and at the
  // deadline it returned last (IoLoop::never: none). It may end the link.
  virtual std::int64_t service(std::int64_t now_ns) {
    (void)now_ns;
    return IoLoop::never;
  }
  // Nothing read for policy.silence_ns: by default a timeout is counted and the link ended.
  virtual void on_silence(std::int64_t now_ns);
  // The rest schedule's policy hook: after a read that took data and published samples, whether to
  // rest (true) or read the next arrival at once (e.g. a bus whose cycles come further apart than a
  // period and whose cycle is complete: there is nothing to batch).
  [[nodiscard]] virtual bool rest_after(const ReadOutcome& read) const {
    (void)read;
    return true;
  }
  // The transport can take output (want_write(true) asked for it).
  virtual void on_writable() {}
  // The device is being stopped while its link is up, before on_link_down(): finish what is under way.
  virtual void on_stop() {}

  // ---- What the skeleton offers the driver.
  void link_up(int fd);  // the descriptor stays the driver's (it closes it in on_link_down)
  void link_failed(const std::string& why);
  // Connects without blocking (a name resolved off the loop): the link comes up with the socket (the
  // skeleton's: closed after on_link_down) or fails with "LABEL: why".
  void connect_tcp(const std::string& host, int port, std::string label, std::chrono::nanoseconds timeout);
  // Ends the link: on_link_down(), state `lost` with `why`, the next open after the back-off.
  void end_link(const std::string& why);
  [[nodiscard]] bool link_is_up() const noexcept { return link_ == Link::up; }
  [[nodiscard]] int link_fd() const noexcept { return fd_; }
  // This link follows an earlier one since start(): what it brings first follows a gap.
  [[nodiscard]] bool relinked() const noexcept { return relinked_; }
  [[nodiscard]] IoLoop& loop() noexcept { return *io_; }
  [[nodiscard]] const LoopPolicy& policy() const noexcept { return policy_; }
  void set_schedule(ReadSchedule schedule) noexcept { schedule_ = schedule; }
  [[nodiscard]] ReadSchedule schedule() const noexcept { return schedule_; }
  // The paced schedule: reads now; false when the link ended. `more` as read_some's.
  bool read_queued(bool& more);
  void want_write(bool on) noexcept { write_wanted_ = on; }
  // service() may run this much before its deadline at another device's pass (sharing its wake-up).
  void set_service_slack(std::int64_t slack_ns) noexcept { service_slack_ns_ = slack_ns; }
  // Whether the loop passed by for another device since `pass` (IoLoop::passes()).
  [[nodiscard]] bool others_passed_since(std::uint64_t pass) const noexcept { return foreign_pass_ > pass; }

 private:
  void attach(IoLoop& loop) final;
  void detach() final;
  enum class Link { waiting, opening, up };
  void connect();
  void up(int fd, bool owned);
  void close_link();
  void wait_backoff();
  void on_ready(std::uint32_t events);
  void on_timer();
  void on_wake();
  void on_settle();
  void hang_up();
  // Reads (read_some) at a pass of the loop and applies the schedule; false when the link ended.
  bool read(bool at_others_pass);
  bool read_once(bool at_others_pass, bool& more);
  void after_read(const ReadOutcome& r, bool samples, bool at_others_pass, std::int64_t now);
  // Silence, the driver's service, then the next wake-up.
  void tick(std::int64_t now);
  // The readiness interest and the timer from the schedule and the deadlines.
  void arm(std::int64_t now);

  LoopPolicy policy_;
  Backoff backoff_;
  IoLoop* io_ = nullptr;
  IoLoop::Id timer_ = 0;
  IoLoop::Id wake_hook_ = 0;
  IoLoop::Id settle_hook_ = 0;
  tcp::LoopConnector connector_;
  bool connector_attached_ = false;
  Link link_ = Link::waiting;
  int fd_ = -1;
  bool owns_fd_ = false;
  bool ever_up_ = false;
  bool relinked_ = false;
  std::string last_end_;  // why the last link ended or failed: said while the next one opens
  std::uint64_t published_at_up_ = 0;
  std::int64_t reconnect_at_ns_ = 0;
  ReadSchedule schedule_ = ReadSchedule::rest;
  std::int64_t last_data_ns_ = 0;
  std::int64_t read_at_ns_ = 0;       // rest: the next read (a future time: resting)
  std::int64_t deadline_ns_ = IoLoop::never;  // service()'s
  std::int64_t service_slack_ns_ = 0;
  std::uint64_t served_pass_ = 0;     // the last pass this driver's descriptor or timer caused, or read at
  std::uint64_t foreign_pass_ = 0;    // the last pass it did not cause
  bool resting_ = false;              // no readiness interest until read_at_ns_
  bool idle_check_ = false;           // a rest ended with an empty read (on_settle decides)
  bool lonely_ = false;               // a rest ended with nothing read anywhere: read per arrival
  bool others_pass_ = false;          // since the last data, the loop passed by for another device
  bool write_wanted_ = false;
};

}  // namespace guideway::drivers
