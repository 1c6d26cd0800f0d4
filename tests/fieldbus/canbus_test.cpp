// The fd layer of the CAN transport: local frame bus relay, CanIface (stamps, deadlines,
// overflow, disconnects, bus-off), SocketCAN socket creation errors.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"

namespace mrd::canbus {
namespace {

using common::MonotonicNs;

std::string TempSocketPath(const char* tag) {
  return "/tmp/mrd-canbus-test-" + std::string(tag) + "-" + std::to_string(getpid()) + ".sock";
}

can_frame Frame(canid_t id, std::uint8_t b0) {
  can_frame f{};
  f.can_id = id;
  f.len = 8;
  f.data[0] = b0;
  return f;
}

// Receives one frame within timeout_ms, stepping the relay meanwhile (same thread).
CanResult ReceiveWithin(CanIface& iface, LocalBusRelay* relay, can_frame* f, int timeout_ms) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (std::chrono::steady_clock::now() < until) {
    if (relay != nullptr) relay->Step(1);
    std::int64_t stamp = 0;
    const CanResult r = iface.Receive(f, &stamp);
    if (r != CanResult::kEmpty) return r;
  }
  return CanResult::kEmpty;
}

TEST(LocalBus, EveryFrameReachesEveryOtherNodeButNotItsSender) {
  const std::string path = TempSocketPath("fanout");
  LocalBusRelay relay;
  std::string error;
  ASSERT_TRUE(relay.Open(path, &error)) << error;
  CanIface a, b, c;
  a.Attach(OpenLocalBusNode(path.c_str(), &error));
  b.Attach(OpenLocalBusNode(path.c_str(), &error));
  c.Attach(OpenLocalBusNode(path.c_str(), &error));
  ASSERT_TRUE(a.is_open() && b.is_open() && c.is_open()) << error;
  for (int i = 0; i < 20 && relay.nodes() < 3; ++i) relay.Step(5);
  ASSERT_EQ(relay.nodes(), 3U);

  const std::int64_t now = MonotonicNs();
  ASSERT_EQ(a.Send(Frame(0x100, 42), now + 1'000'000'000, now), CanResult::kOk);
  can_frame f{};
  ASSERT_EQ(ReceiveWithin(b, &relay, &f, 500), CanResult::kOk);
  EXPECT_EQ(f.can_id, 0x100U);
  EXPECT_EQ(f.data[0], 42);
  ASSERT_EQ(ReceiveWithin(c, &relay, &f, 500), CanResult::kOk);
  EXPECT_EQ(f.data[0], 42);
  EXPECT_EQ(ReceiveWithin(a, &relay, &f, 50), CanResult::kEmpty);  // not echoed to the sender
  EXPECT_EQ(relay.stats().frames_in, 1U);
  EXPECT_EQ(relay.stats().frames_out, 2U);

  // A packet that is not one can_frame is dropped by the relay and counted.
  const char junk[5] = {1, 2, 3, 4, 5};
  ASSERT_EQ(send(a.fd(), junk, sizeof junk, 0), 5);
  EXPECT_EQ(ReceiveWithin(b, &relay, &f, 50), CanResult::kEmpty);
  EXPECT_EQ(relay.stats().bad_packets, 1U);

  // A node leaving is noticed; the others keep talking.
  c.Close();
  for (int i = 0; i < 20 && relay.nodes() > 2; ++i) relay.Step(5);
  EXPECT_EQ(relay.nodes(), 2U);
  ASSERT_EQ(b.Send(Frame(0x101, 7), MonotonicNs() + 1'000'000'000, MonotonicNs()), CanResult::kOk);
  ASSERT_EQ(ReceiveWithin(a, &relay, &f, 500), CanResult::kOk);
  EXPECT_EQ(f.data[0], 7);
  relay.Close();
}

TEST(LocalBus, RefusesALiveSocketAndReplacesAStaleOne) {
  const std::string path = TempSocketPath("stale");
  std::string error;
  {
    LocalBusRelay first;
    ASSERT_TRUE(first.Open(path, &error)) << error;
    LocalBusRelay second;
    EXPECT_FALSE(second.Open(path, &error));
    EXPECT_NE(error.find("already served"), std::string::npos) << error;
  }
  // A socket file nobody listens on (a relay killed without cleaning up).
  const int fd = socket(AF_UNIX, SOCK_SEQPACKET, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  close(fd);
  EXPECT_LT(OpenLocalBusNode(path.c_str(), &error), 0);
  EXPECT_NE(error.find("cannot connect to local bus"), std::string::npos) << error;
  LocalBusRelay relay;
  ASSERT_TRUE(relay.Open(path, &error)) << error;
  const int node = OpenLocalBusNode(path.c_str(), &error);
  EXPECT_GE(node, 0) << error;
  if (node >= 0) close(node);
}

TEST(CanIface, ReceiveStampsFramesAndReportsWrongSizesEofAndBusOff) {
  int sv[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  CanIface iface;
  iface.Attach(sv[0]);
  can_frame f{};
  std::int64_t stamp = 0;
  EXPECT_EQ(iface.Receive(&f, &stamp), CanResult::kEmpty);

  const can_frame sent = Frame(0x180, 9);
  const std::int64_t before = MonotonicNs();
  ASSERT_EQ(write(sv[1], &sent, sizeof sent), static_cast<ssize_t>(sizeof sent));
  ASSERT_EQ(iface.Receive(&f, &stamp), CanResult::kOk);
  EXPECT_GE(stamp, before);
  EXPECT_LE(stamp, MonotonicNs());
  EXPECT_EQ(f.data[0], 9);

  const char short_packet[8] = {};
  ASSERT_EQ(write(sv[1], short_packet, sizeof short_packet), 8);
  EXPECT_EQ(iface.Receive(&f, &stamp), CanResult::kBadFrame);
  canfd_frame fd_frame{};
  ASSERT_EQ(write(sv[1], &fd_frame, sizeof fd_frame), static_cast<ssize_t>(sizeof fd_frame));
  EXPECT_EQ(iface.Receive(&f, &stamp), CanResult::kBadFrame);
  EXPECT_EQ(iface.stats().rx_bad, 2U);

  can_frame err{};
  err.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  err.len = CAN_ERR_DLC;
  ASSERT_EQ(write(sv[1], &err, sizeof err), static_cast<ssize_t>(sizeof err));
  EXPECT_EQ(iface.Receive(&f, &stamp), CanResult::kBusOff);
  EXPECT_EQ(iface.stats().bus_off, 1U);

  close(sv[1]);
  EXPECT_EQ(iface.Receive(&f, &stamp), CanResult::kDisconnected);
  EXPECT_FALSE(iface.is_open());
  EXPECT_EQ(iface.stats().disconnects, 1U);
  EXPECT_EQ(iface.Send(sent, MonotonicNs() + 1'000'000, MonotonicNs()), CanResult::kDisconnected);
}

// Packets that wait together are read in one call and handed out one by one: in order, each
// with its own result (a bad size, an error frame, the peer's EOF last), none lost or repeated.
TEST(CanIface, PacketsReadAheadComeOutInOrderWithTheirOwnResults) {
  int sv[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  CanIface iface;
  iface.Attach(sv[0]);
  const std::int64_t before = MonotonicNs();
  for (std::uint8_t i = 0; i < 3; ++i) {
    const can_frame f = Frame(0x100 + i, i);
    ASSERT_EQ(write(sv[1], &f, sizeof f), static_cast<ssize_t>(sizeof f));
  }
  const char short_packet[8] = {};
  ASSERT_EQ(write(sv[1], short_packet, sizeof short_packet), 8);
  can_frame err{};
  err.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  err.len = CAN_ERR_DLC;
  ASSERT_EQ(write(sv[1], &err, sizeof err), static_cast<ssize_t>(sizeof err));
  // More than one read-ahead batch.
  for (std::uint8_t i = 0; i < CanIface::kRxBatch + 2; ++i) {
    LocalBusPacket p{Frame(0x200, i), before - 1000 - i};  // a relay's earlier bus stamp
    ASSERT_EQ(write(sv[1], &p, sizeof p), static_cast<ssize_t>(sizeof p));
  }
  close(sv[1]);

  can_frame f{};
  std::int64_t stamp = 0;
  for (std::uint8_t i = 0; i < 3; ++i) {
    ASSERT_EQ(iface.Receive(&f, &stamp), CanResult::kOk) << int{i};
    EXPECT_EQ(f.can_id, 0x100U + i);
    EXPECT_EQ(f.data[0], i);
    EXPECT_GE(stamp, before);
    EXPECT_LE(stamp, MonotonicNs());
    EXPECT_TRUE(iface.Readable());
  }
  EXPECT_GT(iface.buffered(), 0U);
  EXPECT_EQ(iface.Receive(&f, &stamp), CanResult::kBadFrame);
  EXPECT_EQ(iface.Receive(&f, &stamp), CanResult::kBusOff);
  for (std::uint8_t i = 0; i < CanIface::kRxBatch + 2; ++i) {
    ASSERT_EQ(iface.Receive(&f, &stamp), CanResult::kOk) << int{i};
    EXPECT_EQ(f.can_id, 0x200U);
    EXPECT_EQ(f.data[0], i);
    EXPECT_EQ(stamp, before - 1000 - i);
  }
  EXPECT_EQ(iface.Receive(&f, &stamp), CanResult::kDisconnected);
  EXPECT_FALSE(iface.is_open());
  EXPECT_EQ(iface.buffered(), 0U);
  EXPECT_EQ(iface.stats().rx_frames, 3U + CanIface::kRxBatch + 2);
  EXPECT_EQ(iface.stats().rx_bad, 1U);
  EXPECT_EQ(iface.stats().bus_off, 1U);
}

// Between Hold and Release nothing is written; Release writes the held frames in order (a
// frame already past its deadline when sent is dropped at once, as without holding).
TEST(CanIface, HeldFramesLeaveTogetherOnRelease) {
  int sv[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  CanIface iface;
  iface.Attach(sv[0]);
  const std::int64_t now = MonotonicNs();
  iface.Hold();
  EXPECT_TRUE(iface.held());
  for (std::uint8_t i = 0; i < 3; ++i) {
    EXPECT_EQ(iface.Send(Frame(0x80 + i, i), now + 1'000'000, now), CanResult::kOk);
  }
  EXPECT_EQ(iface.Send(Frame(0x90, 9), now - 1, now), CanResult::kTimedOut);
  can_frame f{};
  EXPECT_LT(recv(sv[1], &f, sizeof f, MSG_DONTWAIT), 0);  // held
  EXPECT_EQ(iface.pending(), 3U);
  EXPECT_EQ(iface.Release(now), CanResult::kOk);
  EXPECT_FALSE(iface.held());
  EXPECT_EQ(iface.pending(), 0U);
  for (std::uint8_t i = 0; i < 3; ++i) {
    ASSERT_EQ(recv(sv[1], &f, sizeof f, MSG_DONTWAIT), static_cast<ssize_t>(sizeof f));
    EXPECT_EQ(f.can_id, 0x80U + i);
  }
  EXPECT_LT(recv(sv[1], &f, sizeof f, MSG_DONTWAIT), 0);
  EXPECT_EQ(iface.stats().tx_frames, 3U);
  EXPECT_EQ(iface.stats().tx_timedout, 1U);
  // More than the queue holds: the full queue is written at once, nothing is lost.
  iface.Hold();
  for (std::size_t i = 0; i < CanIface::kTxQueue + 3; ++i) {
    EXPECT_EQ(iface.Send(Frame(0x100, static_cast<std::uint8_t>(i)), now + 1'000'000, now),
              CanResult::kOk);
  }
  EXPECT_EQ(iface.Release(now), CanResult::kOk);
  for (std::size_t i = 0; i < CanIface::kTxQueue + 3; ++i) {
    ASSERT_EQ(recv(sv[1], &f, sizeof f, MSG_DONTWAIT), static_cast<ssize_t>(sizeof f));
    EXPECT_EQ(f.data[0], i);
  }
  close(sv[1]);
}

TEST(CanIface, FramesPastTheirDeadlineAreDroppedNeverSentLate) {
  int sv[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  CanIface iface;
  iface.Attach(sv[0]);
  const std::int64_t now = MonotonicNs();
  // Deadline already passed: dropped, nothing on the wire.
  EXPECT_EQ(iface.Send(Frame(0x80, 1), now - 1, now), CanResult::kTimedOut);
  EXPECT_EQ(iface.stats().tx_timedout, 1U);
  can_frame f{};
  EXPECT_LT(recv(sv[1], &f, sizeof f, MSG_DONTWAIT), 0);

  // Fill the socket until the fd would block: frames then wait in the queue, the queue fills
  // (overflow), and when time passes their deadlines they are dropped, not sent late.
  int sent = 0;
  while (iface.pending() == 0 && sent < 100000) {
    ASSERT_EQ(iface.Send(Frame(0x80, 2), now + 1'000'000, now), CanResult::kOk);
    ++sent;
  }
  ASSERT_EQ(iface.pending(), 1U);
  for (std::size_t i = 1; i < CanIface::kTxQueue; ++i) {
    EXPECT_EQ(iface.Send(Frame(0x80, 3), now + 1'000'000, now), CanResult::kOk);
  }
  EXPECT_EQ(iface.Send(Frame(0x80, 4), now + 1'000'000, now), CanResult::kOverflow);
  EXPECT_EQ(iface.stats().tx_overflow, 1U);
  const std::uint64_t written = iface.stats().tx_frames;
  // Drain the peer, then flush after every deadline: all queued frames are dropped.
  while (recv(sv[1], &f, sizeof f, MSG_DONTWAIT) > 0) {
  }
  EXPECT_EQ(iface.Flush(now + 2'000'000), CanResult::kTimedOut);
  EXPECT_EQ(iface.pending(), 0U);
  EXPECT_EQ(iface.stats().tx_frames, written);
  EXPECT_EQ(iface.stats().tx_timedout, 1U + CanIface::kTxQueue);
  EXPECT_LT(recv(sv[1], &f, sizeof f, MSG_DONTWAIT), 0);
  close(sv[1]);
}

TEST(SocketCan, OpeningAMissingInterfaceFailsWithAClearReason) {
  std::string error;
  const can_filter filter{0x100, CAN_SFF_MASK};
  const int fd = OpenSocketCan("mrdcan9", &filter, 1, &error);
  ASSERT_LT(fd, 0);
  EXPECT_EQ(error.rfind("can: ", 0), 0U) << error;
  EXPECT_NE(error.find("mrdcan9"), std::string::npos) << error;
  EXPECT_LT(OpenSocketCan("", &filter, 1, &error), 0);
  EXPECT_LT(OpenSocketCan("an-interface-name-too-long", &filter, 1, &error), 0);
  EXPECT_TRUE(IsLocalBusPath("/tmp/bus.sock"));
  EXPECT_FALSE(IsLocalBusPath("can0"));
}

}  // namespace
}  // namespace mrd::canbus
