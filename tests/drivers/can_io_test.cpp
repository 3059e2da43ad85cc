// CAN frame I/O: can_frame records over socketpair(AF_UNIX, SOCK_SEQPACKET) and the Unix gateway
// socket; truncated and oversized records, EOF, wake-ups; a real SocketCAN (vcan) round trip where
// this kernel has AF_CAN, skipped with the errno text where it does not.
#include <gtest/gtest.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <thread>
#include <vector>

#include "drivers/can/can_io.hpp"
#include "test_support.hpp"

using namespace guideway::drivers::can;

namespace {

struct Pair {
  Pair() {
    int sv[2];
    if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) < 0) throw std::runtime_error("socketpair");
    a.reset(sv[0]);
    b.reset(sv[1]);
  }
  CanSocket a, b;
};

std::int64_t realtime_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

can_frame frame(canid_t id, std::uint8_t dlc, std::uint8_t fill) {
  can_frame f{};
  f.can_id = id;
  f.can_dlc = dlc;
  std::memset(f.data, fill, sizeof f.data);
  return f;
}

}  // namespace

TEST(CanIo, FramesCrossASocketpairWholeAndInOrder) {
  Pair p;
  std::string err;
  for (std::uint8_t i = 0; i < 50; ++i) ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x180 + i, 4, i), err)) << err;
  for (std::uint8_t i = 0; i < 50; ++i) {
    can_frame f{};
    ASSERT_EQ(read_can_frame(p.b.fd(), f, 1000, -1, err), ReadResult::frame);
    EXPECT_EQ(f.can_id, 0x180u + i);
    EXPECT_EQ(f.can_dlc, 4);
    EXPECT_EQ(f.data[3], i);
  }
  can_frame f{};
  EXPECT_EQ(read_can_frame(p.b.fd(), f, 10, -1, err), ReadResult::timeout);
}

TEST(CanIo, TruncatedAndOversizedRecordsAreReportedAndSkipped) {
  Pair p;
  std::string err;
  const can_frame good = frame(0x181, 4, 7);
  ASSERT_TRUE(write_can_record(p.a.fd(), &good, 9, err));
  unsigned char big[sizeof(can_frame) + 8] = {};
  ASSERT_TRUE(write_can_record(p.a.fd(), big, sizeof big, err));
  ASSERT_TRUE(write_can_frame(p.a.fd(), good, err));
  can_frame f{};
  EXPECT_EQ(read_can_frame(p.b.fd(), f, 1000, -1, err), ReadResult::truncated);
  EXPECT_EQ(read_can_frame(p.b.fd(), f, 1000, -1, err), ReadResult::truncated);
  ASSERT_EQ(read_can_frame(p.b.fd(), f, 1000, -1, err), ReadResult::frame);
  EXPECT_EQ(f.can_id, 0x181u);
}

TEST(CanIo, EofComesAfterEveryQueuedFrameEvenWhenThePeerLeftOurFramesUnread) {
  Pair p;
  std::string err;
  ASSERT_TRUE(write_can_frame(p.b.fd(), frame(0x080, 0, 0), err));  // unread by a: close gives ECONNRESET
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x181, 4, 1), err));
  p.a.reset();
  can_frame f{};
  for (int i = 0; i < 3; ++i) ASSERT_EQ(read_can_frame(p.b.fd(), f, 1000, -1, err), ReadResult::frame) << i;
  EXPECT_EQ(read_can_frame(p.b.fd(), f, 1000, -1, err), ReadResult::closed);
  EXPECT_FALSE(write_can_frame(p.b.fd(), frame(0x080, 0, 0), err));
  EXPECT_NE(err.find("send"), std::string::npos);
}

TEST(CanIo, AWakeFdInterruptsAWait) {
  Pair p;
  const int wake = ::eventfd(0, EFD_CLOEXEC);
  std::thread t([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::uint64_t one = 1;
    (void)!::write(wake, &one, sizeof one);
  });
  can_frame f{};
  std::string err;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(read_can_frame(p.b.fd(), f, 5000, wake, err), ReadResult::woken);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  t.join();
  ::close(wake);
}

TEST(CanIo, EndpointsParseAndTheGatewayConnects) {
  CanEndpoint e;
  std::string err;
  ASSERT_TRUE(parse_can_endpoint("vcan0", e, err));
  EXPECT_EQ(e.kind, CanEndpoint::Kind::socketcan);
  EXPECT_EQ(to_string(e), "can:vcan0");
  ASSERT_TRUE(parse_can_endpoint("unix:/tmp/x.sock", e, err));
  EXPECT_EQ(e.kind, CanEndpoint::Kind::unix_gateway);
  EXPECT_EQ(e.name, "/tmp/x.sock");
  EXPECT_FALSE(parse_can_endpoint("unix:", e, err));
  EXPECT_FALSE(parse_can_endpoint("can:averyveryverylongname", e, err));

  guideway::test::TempDir dir;
  const std::string path = dir.file("gw.sock");
  EXPECT_FALSE(connect_can_gateway(path, err).valid());
  EXPECT_NE(err.find("connect"), std::string::npos);
  CanSocket listener = listen_can_gateway(path, err);
  ASSERT_TRUE(listener.valid()) << err;
  ASSERT_TRUE(parse_can_endpoint("unix:" + path, e, err));
  CanSocket client = open_can_endpoint(e, err);
  ASSERT_TRUE(client.valid()) << err;
  CanSocket server(::accept(listener.fd(), nullptr, nullptr));
  ASSERT_TRUE(server.valid());
  ASSERT_TRUE(write_can_frame(server.fd(), frame(0x183, 4, 9), err));
  can_frame f{};
  ASSERT_EQ(read_can_frame(client.fd(), f, 1000, -1, err), ReadResult::frame);
  EXPECT_EQ(f.can_id, 0x183u);
}

// A frame the gateway sends the moment it accepts, before the client could have asked for
// timestamps, still carries its send time: the connection asks before connecting.
TEST(CanIo, TheGatewayConnectionIsTimestampedFromItsFirstFrame) {
  guideway::test::TempDir dir;
  const std::string path = dir.file("gw.sock");
  std::string err;
  CanSocket listener = listen_can_gateway(path, err);
  ASSERT_TRUE(listener.valid()) << err;
  CanSocket client = connect_can_gateway(path, err);
  ASSERT_TRUE(client.valid()) << err;
  CanSocket server(::accept(listener.fd(), nullptr, nullptr));
  ASSERT_TRUE(server.valid());
  const std::int64_t before = realtime_ns();
  ASSERT_TRUE(write_can_frame(server.fd(), frame(0x080, 0, 0), err)) << err;
  const std::int64_t after = realtime_ns();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::array<can_frame, 4> frames{};
  std::array<std::int64_t, 4> rx{};
  FrameBatch batch;
  ASSERT_EQ(read_can_frames(client.fd(), frames, rx, batch, err), ReadResult::frame);
  ASSERT_EQ(batch.count, 1u);
  EXPECT_EQ(batch.untimed, 0u);
  EXPECT_GE(rx[0], before);
  EXPECT_LE(rx[0], after) << "stamped at the read, 20 ms late";
}

TEST(CanIo, RealVcanRoundTripWhereTheKernelHasAfCan) {
  std::string reason;
  if (!socketcan_available(reason)) GTEST_SKIP() << "no SocketCAN in this kernel: " << reason;
  const char* ifname = std::getenv("GUIDEWAY_VCAN");
  const std::string name = ifname ? ifname : "vcan0";
  std::string err;
  CanSocket a = open_socketcan(name, err);
  if (!a.valid())
    GTEST_SKIP() << "AF_CAN works but " << name << " is not usable (create it with `ip link add dev " << name
                 << " type vcan && ip link set up " << name << "`): " << err;
  CanSocket b = open_socketcan(name, err);
  ASSERT_TRUE(b.valid()) << err;
  ASSERT_TRUE(enable_rx_timestamps(b.fd(), err)) << err;
  const std::int64_t before = realtime_ns();
  ASSERT_TRUE(write_can_frame(a.fd(), frame(0x185, 4, 3), err)) << err;
  can_frame f{};
  ASSERT_EQ(read_can_frame(b.fd(), f, 1000, -1, err), ReadResult::frame) << err;
  EXPECT_EQ(f.can_id, 0x185u);
  EXPECT_EQ(f.data[0], 3);
  // SocketCAN stamps at reception: the batch read gets the time with the frame.
  ASSERT_TRUE(write_can_frame(a.fd(), frame(0x186, 4, 4), err)) << err;
  std::array<can_frame, 4> frames{};
  std::array<std::int64_t, 4> rx{};
  FrameBatch batch;
  ASSERT_TRUE(guideway::test::eventually([&] {
    return read_can_frames(b.fd(), frames, rx, batch, err) == ReadResult::frame;
  }));
  ASSERT_EQ(batch.count, 1u);
  EXPECT_EQ(batch.untimed, 0u);
  EXPECT_GE(rx[0], before);
  EXPECT_LE(rx[0], realtime_ns());
}

TEST(CanIo, OpeningSocketCanWithoutAfCanSaysWhy) {
  std::string reason;
  if (socketcan_available(reason)) GTEST_SKIP() << "this kernel has AF_CAN";
  std::string err;
  EXPECT_FALSE(open_socketcan("vcan0", err).valid());
  EXPECT_NE(err.find("socket(AF_CAN)"), std::string::npos) << err;
}

TEST(CanIo, ABatchReadTakesEveryQueuedFrameInOrderAndCountsBadRecords) {
  Pair p;
  std::string err;
  std::array<can_frame, 8> frames{};
  FrameBatch batch;
  EXPECT_EQ(read_can_frames(p.b.fd(), frames, batch, err), ReadResult::timeout);  // nothing queued: no wait
  EXPECT_EQ(batch.count, 0u);
  for (std::uint8_t i = 0; i < 3; ++i) ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x181 + i, 4, i), err));
  const can_frame good = frame(0x1A0, 4, 9);
  ASSERT_TRUE(write_can_record(p.a.fd(), &good, 9, err));  // truncated
  unsigned char big[sizeof(can_frame) + 8] = {};
  ASSERT_TRUE(write_can_record(p.a.fd(), big, sizeof big, err));  // oversized (CAN FD)
  for (std::uint8_t i = 0; i < 7; ++i) ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x200 + i, 4, i), err));
  // 12 records, 8 slots: two reads, whole frames in arrival order, the bad records counted.
  ASSERT_EQ(read_can_frames(p.b.fd(), frames, batch, err), ReadResult::frame);
  EXPECT_EQ(batch.count + batch.truncated, 8u);
  EXPECT_EQ(batch.truncated, 2u);
  std::vector<canid_t> ids;
  for (std::size_t i = 0; i < batch.count; ++i) ids.push_back(frames[i].can_id);
  ASSERT_EQ(read_can_frames(p.b.fd(), frames, batch, err), ReadResult::frame);
  EXPECT_EQ(batch.count, 4u);
  EXPECT_EQ(batch.truncated, 0u);
  for (std::size_t i = 0; i < batch.count; ++i) ids.push_back(frames[i].can_id);
  const std::vector<canid_t> want = {0x181, 0x182, 0x183, 0x200, 0x201, 0x202, 0x203, 0x204, 0x205, 0x206};
  EXPECT_EQ(ids, want);
  EXPECT_EQ(read_can_frames(p.b.fd(), frames, batch, err), ReadResult::timeout);
}

TEST(CanIo, ABatchReadSeesEofOnlyAfterEveryQueuedFrameAlsoAfterAReset) {
  Pair p;
  std::string err;
  ASSERT_TRUE(write_can_frame(p.b.fd(), frame(0x080, 0, 0), err));  // unread by a: close gives ECONNRESET
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x181, 4, static_cast<std::uint8_t>(i)), err));
  p.a.reset();
  std::array<can_frame, 4> frames{};
  std::size_t got = 0;
  ReadResult r = ReadResult::frame;
  for (int reads = 0; reads < 10 && r == ReadResult::frame; ++reads) {
    FrameBatch batch;
    r = read_can_frames(p.b.fd(), frames, batch, err);
    for (std::size_t i = 0; i < batch.count; ++i) EXPECT_EQ(frames[i].data[0], got + i);
    got += batch.count;
  }
  EXPECT_EQ(got, 5u);
  EXPECT_EQ(r, ReadResult::closed) << err;
}

// SO_TIMESTAMPNS on an AF_UNIX SEQPACKET socket: the kernel stamps each frame when the peer sends it,
// so frames read together keep the times they were sent apart.
TEST(CanIo, ABatchReadGivesEachFrameItsKernelReceiveTime) {
  Pair p;
  std::string err;
  ASSERT_TRUE(enable_rx_timestamps(p.b.fd(), err)) << err;
  std::array<std::int64_t, 3> before{}, after{};
  for (std::size_t i = 0; i < 3; ++i) {
    if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    before[i] = realtime_ns();
    ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x181, 4, static_cast<std::uint8_t>(i)), err)) << err;
    after[i] = realtime_ns();
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::array<can_frame, 8> frames{};
  std::array<std::int64_t, 8> rx{};
  FrameBatch batch;
  ASSERT_EQ(read_can_frames(p.b.fd(), frames, rx, batch, err), ReadResult::frame);
  ASSERT_EQ(batch.count, 3u);
  EXPECT_EQ(batch.untimed, 0u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(frames[i].data[0], i);
    EXPECT_GE(rx[i], before[i]) << i;
    EXPECT_LE(rx[i], after[i]) << i << ": stamped at the send, not at the read";
  }
  EXPECT_GE(rx[2] - rx[1], 5'000'000);
  // Truncated records are counted as before and take no timestamp slot.
  const can_frame good = frame(0x182, 4, 1);
  ASSERT_TRUE(write_can_record(p.a.fd(), &good, 9, err));
  ASSERT_TRUE(write_can_frame(p.a.fd(), good, err));
  ASSERT_EQ(read_can_frames(p.b.fd(), frames, rx, batch, err), ReadResult::frame);
  EXPECT_EQ(batch.truncated, 1u);
  ASSERT_EQ(batch.count, 1u);
  EXPECT_NE(rx[0], no_rx_timestamp);
  // Too few timestamp slots is a caller's error, not an overflow.
  std::array<std::int64_t, 2> few{};
  EXPECT_EQ(read_can_frames(p.b.fd(), frames, few, batch, err), ReadResult::error);
  EXPECT_NE(err.find("timestamp"), std::string::npos) << err;
}

TEST(CanIo, WithoutKernelTimestampsFramesAreReadAndCountedUntimed) {
  Pair p;
  std::string err;
  for (std::uint8_t i = 0; i < 4; ++i) ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x181, 4, i), err));
  std::array<can_frame, 8> frames{};
  std::array<std::int64_t, 8> rx{};
  FrameBatch batch;
  ASSERT_EQ(read_can_frames(p.b.fd(), frames, rx, batch, err), ReadResult::frame);
  ASSERT_EQ(batch.count, 4u);
  EXPECT_EQ(batch.untimed, 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(rx[i], no_rx_timestamp) << i;
  // Without timestamp slots nothing is asked for, so nothing is counted.
  ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x181, 4, 9), err));
  ASSERT_EQ(read_can_frames(p.b.fd(), frames, batch, err), ReadResult::frame);
  EXPECT_EQ(batch.count, 1u);
  EXPECT_EQ(batch.untimed, 0u);
}

TEST(CanIo, TheTimestampControlMessageIsFoundAmongOthersAndOnlyWhenWhole) {
  alignas(cmsghdr) unsigned char control[CMSG_SPACE(sizeof(ucred)) + CMSG_SPACE(sizeof(timespec))] = {};
  msghdr m{};
  EXPECT_EQ(rx_timestamp_ns(m), no_rx_timestamp) << "no control data";
  m.msg_control = control;
  m.msg_controllen = sizeof control;
  // First a credentials message (another SOL_SOCKET type), then the timestamp.
  cmsghdr* c = CMSG_FIRSTHDR(&m);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SCM_CREDENTIALS;
  c->cmsg_len = CMSG_LEN(sizeof(ucred));
  EXPECT_EQ(rx_timestamp_ns(m), no_rx_timestamp) << "only credentials";
  c = CMSG_NXTHDR(&m, c);
  ASSERT_NE(c, nullptr);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SCM_TIMESTAMPNS;
  c->cmsg_len = CMSG_LEN(sizeof(timespec));
  const timespec ts{1'763'700'000, 123'456'789};
  std::memcpy(CMSG_DATA(c), &ts, sizeof ts);
  EXPECT_EQ(rx_timestamp_ns(m), 1'763'700'000'123'456'789);
  m.msg_flags = MSG_CTRUNC;
  EXPECT_EQ(rx_timestamp_ns(m), no_rx_timestamp) << "truncated control data is not trusted";
  m.msg_flags = 0;
  c->cmsg_len = CMSG_LEN(sizeof(timespec) - 4);
  EXPECT_EQ(rx_timestamp_ns(m), no_rx_timestamp) << "a short timestamp message";
  c->cmsg_len = CMSG_LEN(sizeof(timespec));
  c->cmsg_level = SOL_SOCKET + 1;
  EXPECT_EQ(rx_timestamp_ns(m), no_rx_timestamp) << "same type, other level";
}

TEST(CanIo, TheKernelsDropCountIsReadBesideTheTimestamp) {
  alignas(cmsghdr) unsigned char control[CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t))] = {};
  msghdr m{};
  EXPECT_EQ(rx_drop_count(m), 0u) << "no control data";
  m.msg_control = control;
  m.msg_controllen = sizeof control;
  cmsghdr* c = CMSG_FIRSTHDR(&m);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SCM_TIMESTAMPNS;
  c->cmsg_len = CMSG_LEN(sizeof(timespec));
  const timespec ts{1'763'700'000, 5};
  std::memcpy(CMSG_DATA(c), &ts, sizeof ts);
  EXPECT_EQ(rx_drop_count(m), 0u) << "only a timestamp";
  c = CMSG_NXTHDR(&m, c);
  ASSERT_NE(c, nullptr);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SO_RXQ_OVFL;
  c->cmsg_len = CMSG_LEN(sizeof(std::uint32_t));
  const std::uint32_t drops = 17;
  std::memcpy(CMSG_DATA(c), &drops, sizeof drops);
  EXPECT_EQ(rx_drop_count(m), 17u);
  EXPECT_EQ(rx_timestamp_ns(m), 1'763'700'000'000'000'005);
  c->cmsg_len = CMSG_LEN(2);
  EXPECT_EQ(rx_drop_count(m), 0u) << "a short drop count";
}

// A Unix socket accepts SO_RXQ_OVFL and never reports drops (its sender waits instead); frames and
// their timestamps come as before.
TEST(CanIo, AskingForDropCountsOnAUnixSocketChangesNothingElse) {
  Pair p;
  std::string err;
  ASSERT_TRUE(enable_rx_timestamps(p.b.fd(), err)) << err;
  ASSERT_TRUE(enable_rx_drop_count(p.b.fd(), err)) << err;
  for (std::uint8_t i = 0; i < 3; ++i) ASSERT_TRUE(write_can_frame(p.a.fd(), frame(0x181, 4, i), err));
  std::array<can_frame, 8> frames{};
  std::array<std::int64_t, 8> rx{};
  FrameBatch batch;
  ASSERT_EQ(read_can_frames(p.b.fd(), frames, rx, batch, err), ReadResult::frame);
  EXPECT_EQ(batch.count, 3u);
  EXPECT_EQ(batch.untimed, 0u);
  EXPECT_EQ(batch.kernel_drops, 0u);
}
