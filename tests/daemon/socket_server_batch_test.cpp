// SocketServer's batched fan-out: lines queued in a Batch reach each client whole and in order when
// the batch ends, also when the client's socket buffer takes only part of them (partial writes across
// lines, the rest on EPOLLOUT), a client that does not read is still dropped on overflow, and a
// line longer than the whole queue reaches a client that keeps up.
#include "daemon/socket_server.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "test_support.hpp"

using namespace guideway::daemon;

namespace {

int connect_unix(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) throw std::runtime_error("connect");
  return fd;
}

std::string line_of(int i) { return "{\"n\":" + std::to_string(i) + ",\"pad\":\"" + std::string(i % 97, 'x') + "\"}"; }

// Reads fd in reads of at most `chunk` bytes until `complete(received)` or the connection ends, then sets done.
std::thread read_in_background(int fd, std::size_t chunk, std::function<bool(const std::string&)> complete,
                               std::string& received, std::atomic<bool>& done) {
  return std::thread([fd, chunk, complete = std::move(complete), &received, &done] {
    std::vector<char> buf(chunk);
    while (!complete(received)) {
      const ssize_t n = ::read(fd, buf.data(), buf.size());
      if (n <= 0) break;
      received.append(buf.data(), static_cast<std::size_t>(n));
    }
    done = true;
  });
}
auto has_bytes(std::size_t bytes) {
  return [bytes](const std::string& r) { return r.size() >= bytes; };
}

}  // namespace

TEST(SocketServerBatch, ABatchArrivesWholeAndInOrderThroughPartialWrites) {
  guideway::test::TempDir dir;
  EventLoop loop;
  SocketServerOptions o;
  o.unix_path = dir.file("s.sock");
  o.max_queue_bytes = 64 << 20;
  std::vector<ClientId> ids;
  SocketServer server(loop, o);
  server.on_connect([&](ClientId id) { ids.push_back(id); });
  constexpr int lines = 20000;  // ~1.3 MB: far more than the socket buffer, so writes are partial
  std::size_t bytes = 0;
  for (int i = 0; i < lines; ++i) bytes += line_of(i).size() + 1;

  const int fd = connect_unix(o.unix_path);
  const int small = 4096;
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  std::string received;
  std::atomic<bool> done{false};
  std::thread reader = read_in_background(fd, 1000, has_bytes(bytes), received, done);  // small reads, slower than the writer
  bool sent = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  loop.run(5, [&] {
    if (!sent && !ids.empty()) {
      const SocketServer::Batch batch(server);
      for (int i = 0; i < lines; ++i) ASSERT_TRUE(server.send(ids[0], line_of(i)));
      EXPECT_GT(server.queued_bytes(ids[0]), 0u);  // nothing written before the batch ends
      sent = true;
    }
    if (done || std::chrono::steady_clock::now() > deadline) loop.stop();
  });
  reader.join();
  ::close(fd);
  ASSERT_EQ(received.size(), bytes);
  std::size_t pos = 0;
  for (int i = 0; i < lines; ++i) {
    const std::string want = line_of(i) + "\n";
    ASSERT_EQ(received.compare(pos, want.size(), want), 0) << "line " << i;
    pos += want.size();
  }
}

TEST(SocketServerBatch, AClientThatDoesNotReadIsDroppedAndTheOthersStillGetEveryLine) {
  guideway::test::TempDir dir;
  EventLoop loop;
  SocketServerOptions o;
  o.unix_path = dir.file("s.sock");
  o.max_queue_bytes = 65536;
  std::vector<ClientId> ids;
  std::vector<std::string> reasons;  // before the server: its destructor reports the last disconnects
  SocketServer server(loop, o);
  server.on_connect([&](ClientId id) { ids.push_back(id); });
  server.on_disconnect([&](ClientId, const std::string& why) { reasons.push_back(why); });
  const int silent = connect_unix(o.unix_path);
  const int reading = connect_unix(o.unix_path);
  std::string received;
  std::atomic<bool> done{false};
  constexpr int rounds = 1000, per_round = 20;  // ~1.3 MB: more than the silent one's socket buffer + queue
  std::size_t bytes = 0;
  for (int i = 0; i < rounds * per_round; ++i) bytes += line_of(i).size() + 1;
  std::thread reader = read_in_background(reading, 65536, has_bytes(bytes), received, done);
  int round = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  loop.run(1, [&] {
    // The next round only when the reading client has taken the last one (a starved test thread must
    // not look like a slow client); the silent one's queue only grows.
    if (ids.size() == 2 && round < rounds && server.queued_bytes(ids[1]) == 0) {
      const SocketServer::Batch batch(server);  // like the daemon's outbox batches
      for (int k = 0; k < per_round; ++k) {
        const std::string l = line_of(round * per_round + k);
        for (ClientId id : ids) server.send(id, l);
      }
      ++round;
    }
    if (done || std::chrono::steady_clock::now() > deadline) loop.stop();
  });
  reader.join();
  EXPECT_EQ(received.size(), bytes);
  EXPECT_EQ(server.dropped_clients(), 1u);
  ASSERT_EQ(reasons.size(), 1u);
  EXPECT_NE(reasons[0].find("queue overflow"), std::string::npos);
  ::close(silent);
  ::close(reading);
}

TEST(SocketServerBatch, LinesLongerThanTheQueueReachAClientThatKeepsUpWhileASilentOneIsDropped) {
  guideway::test::TempDir dir;
  EventLoop loop;
  SocketServerOptions o;
  o.unix_path = dir.file("s.sock");
  o.max_queue_bytes = 4096;  // the configuration's smallest
  std::vector<ClientId> ids;
  std::vector<std::string> reasons;
  SocketServer server(loop, o);
  server.on_connect([&](ClientId id) { ids.push_back(id); });
  server.on_disconnect([&](ClientId, const std::string& why) { reasons.push_back(why); });
  const int reading = connect_unix(o.unix_path);
  const int silent = connect_unix(o.unix_path);
  const std::string big = "{\"class\":\"EXPLAIN\",\"pad\":\"" + std::string(100'000, 'x') + "\"}";
  const std::string small = "{\"class\":\"PARAMS\"}";
  const std::string end = "{\"end\":true}";
  // Longer than a socket buffer, so it is still being written when the next line comes.
  const std::string huge = "{\"class\":\"EXPLAIN\",\"pad\":\"" + std::string(2'000'000, 'y') + "\"}";
  std::string received;
  std::atomic<bool> done{false};
  std::thread reader;  // started once the huge line is in flight (a reader already running could take it whole)
  // Rounds of small, small, big in one Batch (as the daemon posts PARAMS and then EXPLAIN), the next
  // once the reading client has taken the last, until the silent one (whose socket buffer takes a
  // few lines, however large the host makes it) is dropped.
  int rounds = 0;
  bool started = false, ended = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  loop.run(1, [&] {
    if (ids.size() == 2 && !started) {
      started = true;
      EXPECT_TRUE(server.send(ids[0], huge));
      EXPECT_GT(server.queued_bytes(ids[0]), 0u);  // in flight
      EXPECT_TRUE(server.send(ids[0], small)) << "a line behind one in flight is no backlog";
      reader = read_in_background(
          reading, 65536, [&](const std::string& r) { return r.ends_with(end + "\n"); }, received, done);
    }
    if (started && !ended && server.queued_bytes(ids[0]) == 0) {
      const SocketServer::Batch batch(server);
      if (reasons.empty() && rounds < 64) {
        for (ClientId id : ids)
          for (const std::string* l : {&small, &small, &big}) server.send(id, *l);
        ++rounds;
      } else {
        server.send(ids[0], end);
        ended = true;
      }
    }
    if (done || std::chrono::steady_clock::now() > deadline) loop.stop();
  });
  if (!done) ::shutdown(reading, SHUT_RDWR);  // the deadline passed: end the reader's wait
  if (reader.joinable()) reader.join();
  ASSERT_EQ(reasons.size(), 1u) << "the silent client was not dropped in " << rounds << " rounds";
  EXPECT_NE(reasons[0].find("queue overflow"), std::string::npos);
  EXPECT_EQ(server.dropped_clients(), 1u);
  std::string want = huge + "\n" + small + "\n";
  for (int i = 0; i < rounds; ++i) want += small + "\n" + small + "\n" + big + "\n";
  want += end + "\n";
  EXPECT_EQ(received.size(), want.size());
  EXPECT_TRUE(received == want) << "the reading client's lines differ from what was sent";
  ::close(silent);
  ::close(reading);
}

// The race the test above can meet (a round starting while the reader's socket buffer is still full),
// made certain: nobody reads, so whatever is queued stays queued.
TEST(SocketServerBatch, OneLongLineIsNeverHeldAgainstAClientButABacklogBehindItIs) {
  guideway::test::TempDir dir;
  EventLoop loop;
  SocketServerOptions o;
  o.unix_path = dir.file("s.sock");
  o.max_queue_bytes = 4096;
  std::vector<ClientId> ids;
  std::vector<std::string> reasons;
  SocketServer server(loop, o);
  server.on_connect([&](ClientId id) { ids.push_back(id); });
  server.on_disconnect([&](ClientId, const std::string& why) { reasons.push_back(why); });
  const int fd = connect_unix(o.unix_path);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  loop.run(1, [&] {
    if (!ids.empty() || std::chrono::steady_clock::now() > deadline) loop.stop();
  });
  ASSERT_EQ(ids.size(), 1u);
  const std::string huge(4'000'000, 'y');  // more than any socket buffer: stays in flight
  const std::string small(18, 's');
  const std::string big(100'000, 'x');
  ASSERT_TRUE(server.send(ids[0], huge));
  ASSERT_GT(server.queued_bytes(ids[0]), 0u);
  {
    const SocketServer::Batch batch(server);
    EXPECT_TRUE(server.send(ids[0], small));
    EXPECT_TRUE(server.send(ids[0], small));
    EXPECT_TRUE(server.send(ids[0], big)) << "38 bytes wait behind the line in flight: no backlog yet";
  }
  EXPECT_TRUE(reasons.empty());
  EXPECT_FALSE(server.send(ids[0], small)) << "100 KB wait behind the line in flight";
  ASSERT_EQ(reasons.size(), 1u);
  EXPECT_NE(reasons[0].find("queue overflow"), std::string::npos);
  EXPECT_EQ(server.dropped_clients(), 1u);
  ::close(fd);
}

// The socket's path appears only once the server listens, with its mode: a client that waits for
// the path and connects at once is not refused (bound under a temporary name, renamed into place).
TEST(SocketServerListen, ThePathAppearsListeningWithItsModeAndNoTemporaryNameIsLeft) {
  guideway::test::TempDir dir;
  EventLoop loop;
  SocketServerOptions o;
  o.unix_path = dir.file("s.sock");
  o.unix_mode = 0600;
  const SocketServer server(loop, o);
  struct stat st {};
  ASSERT_EQ(::stat(o.unix_path.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_FALSE(std::filesystem::exists(o.unix_path + ".new"));
  const int fd = connect_unix(o.unix_path);  // before the loop ever ran: queued in the backlog
  ::close(fd);
}
