// Conformance of the CAN transport's fd layer (docs/can_bus.md): frames keep the time they
// arrived (the relay's bus stamp on the local bus, the kernel's receive stamp elsewhere), not
// the time they were read; the relay's "already served?" probe never blocks; out of file
// descriptors the relay refuses nodes instead of spinning.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "support/process.hpp"

namespace mrd::canbus {
namespace {

using common::MonotonicNs;

std::string TempSocketPath(const char* tag) {
  return "/tmp/mrd-can-conf-" + std::string(tag) + "-" + std::to_string(getpid()) + ".sock";
}

// A kernel stamp (CLOCK_REALTIME) converted to CLOCK_MONOTONIC may be off by the time between
// the clock reads of the conversion (normally well under a microsecond) [ns].
constexpr std::int64_t kConversionSlackNs = 100'000;

can_frame Frame(canid_t id, std::uint8_t b0) {
  can_frame f{};
  f.can_id = id;
  f.len = 8;
  f.data[0] = b0;
  return f;
}

// A forked child runs body (which must not hang the test): its exit code, or -1 when it had not
// ended after timeout_s (it is then killed).
int InChild(double timeout_s, const std::function<int()>& body) {
  const pid_t pid = fork();
  if (pid == 0) _exit(body());
  return test::ReapWithin(pid, timeout_s);
}

// A listener that never accepts (a relay stopped by SIGSTOP) with its backlog full.
struct StuckListener {
  explicit StuckListener(const std::string& path) {
    fd = socket(AF_UNIX, SOCK_SEQPACKET, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
    unlink(path.c_str());
    if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || listen(fd, 1) != 0) {
      return;
    }
    for (int i = 0; i < 64; ++i) {
      const int node = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0);
      if (connect(node, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        full = errno == EAGAIN;
        close(node);
        break;
      }
      nodes.push_back(node);
    }
  }
  ~StuckListener() {
    for (int n : nodes) close(n);
    close(fd);
  }
  int fd = -1;
  bool full = false;
  std::vector<int> nodes;
};

TEST(LocalBus, TheServedProbeNeverBlocksOnARelayThatDoesNotAccept) {
  const std::string path = TempSocketPath("stuck");
  StuckListener stuck(path);
  ASSERT_TRUE(stuck.full) << "could not fill the listener's backlog";
  // Open probes the socket: before, a blocking connect() waited for room in the backlog
  // forever. Now it answers "already served" after a bounded wait.
  const int rc = InChild(20.0, [&] {
    LocalBusRelay relay;
    std::string error;
    if (relay.Open(path, &error)) return 1;  // replaced a live relay's socket
    return error.find("already served") != std::string::npos ? 0 : 2;
  });
  EXPECT_EQ(rc, 0) << "-1: Open blocked (killed after 20 s); 1: it replaced the live socket";
  unlink(path.c_str());
}

TEST(LocalBus, OutOfDescriptorsANodeIsRefusedAndTheRelayDoesNotSpin) {
  const std::string path = TempSocketPath("emfile");
  // In a child: the descriptor limit is the process's.
  const int rc = InChild(30.0, [&] {
    LocalBusRelay relay;
    std::string error;
    if (!relay.Open(path, &error)) return 10;
    const int node = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0);
    const int probe = dup(node);  // the lowest free descriptor
    close(probe);
    const rlimit limit{static_cast<rlim_t>(probe), static_cast<rlim_t>(probe + 2)};
    if (setrlimit(RLIMIT_NOFILE, &limit) != 0) return 11;
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
    if (connect(node, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return 12;
    for (int i = 0; i < 5; ++i) relay.Step(0);  // accept() fails with EMFILE
    // The node was refused: its connection is closed (EOF), not left in the backlog.
    char buf[32];
    if (recv(node, buf, sizeof buf, MSG_DONTWAIT) != 0) return 1;
    // Nothing is pending any more: a Step waits for its timeout instead of returning at once
    // (before, the listener stayed readable and the relay's loop spun).
    const auto t0 = std::chrono::steady_clock::now();
    relay.Step(300);
    if (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(250)) return 2;
    if (relay.stats().nodes_refused != 1U) return 3;
    // Descriptors to spare again (a raised limit): the next node joins.
    const rlimit more{static_cast<rlim_t>(probe + 2), static_cast<rlim_t>(probe + 2)};
    if (setrlimit(RLIMIT_NOFILE, &more) != 0) return 14;
    const int next = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0);
    if (next < 0 || connect(next, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return 13;
    for (int i = 0; i < 20 && relay.nodes() == 0; ++i) relay.Step(5);
    return relay.nodes() == 1 ? 0 : 4;
  });
  EXPECT_EQ(rc, 0) << "1: the node was not refused; 2: Step returned at once (spinning); "
                      "3: not counted; 4: a later node could not join; -1: hung";
  unlink(path.c_str());
}

TEST(LocalBus, PacketsCarryTheTimeTheFrameEnteredTheBus) {
  const std::string path = TempSocketPath("stamp");
  LocalBusRelay relay;
  std::string error;
  ASSERT_TRUE(relay.Open(path, &error)) << error;
  CanIface a, b;
  a.Attach(OpenLocalBusNode(path.c_str(), &error));
  b.Attach(OpenLocalBusNode(path.c_str(), &error));
  for (int i = 0; i < 20 && relay.nodes() < 2; ++i) relay.Step(5);
  ASSERT_EQ(relay.nodes(), 2U);
  const std::int64_t sent = MonotonicNs();
  ASSERT_EQ(a.Send(Frame(0x100, 5), sent + 1'000'000'000, sent), CanResult::kOk);
  const std::int64_t after_send = MonotonicNs();
  // The relay and the receiver both get round to the frame late.
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  relay.Step(100);
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  can_frame f{};
  std::int64_t stamp = 0;
  ASSERT_EQ(b.Receive(&f, &stamp), CanResult::kOk);
  EXPECT_EQ(f.data[0], 5);
  EXPECT_GE(stamp, sent - kConversionSlackNs);
  EXPECT_LE(stamp, after_send) << "stamped " << (stamp - after_send) / 1000
                               << " us after it was sent: the read's or the relay's time";
  // What a node reads is the frame and its stamp (the documented packet).
  ASSERT_EQ(a.Send(Frame(0x101, 6), MonotonicNs() + 1'000'000'000, MonotonicNs()), CanResult::kOk);
  relay.Step(100);
  LocalBusPacket packet{};
  ASSERT_EQ(recv(b.fd(), &packet, sizeof packet, 0), static_cast<ssize_t>(sizeof packet));
  EXPECT_EQ(packet.frame.can_id, 0x101U);
  EXPECT_EQ(packet.frame.data[0], 6);
  EXPECT_GT(packet.stamp_ns, after_send);
  EXPECT_LE(packet.stamp_ns, MonotonicNs());
  relay.Close();
}

TEST(CanIface, AFrameKeepsItsArrivalStampNotItsReadTime) {
  int sv[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
  CanIface iface;
  iface.Attach(sv[0]);
  const can_frame sent = Frame(0x100, 1);
  const std::int64_t before = MonotonicNs();
  ASSERT_EQ(write(sv[1], &sent, sizeof sent), static_cast<ssize_t>(sizeof sent));
  const std::int64_t written = MonotonicNs();
  std::this_thread::sleep_for(std::chrono::milliseconds(40));  // the reader was held up
  can_frame f{};
  std::int64_t stamp = 0;
  ASSERT_EQ(iface.Receive(&f, &stamp), CanResult::kOk);
  EXPECT_GE(stamp, before - kConversionSlackNs);
  EXPECT_LE(stamp, written) << "stamped " << (stamp - written) / 1000 << " us after it arrived";
  close(sv[1]);
}

TEST(CanIface, AKernelStampIsConvertedToTheMonotonicClockAndAFutureOneIsOld) {
  // Arrived 2.5 ms before "now" on the wall clock: 2.5 ms before now on the monotonic one.
  const timespec rt{1000, 500'000'000};
  EXPECT_EQ(ArrivalStamp(rt, 7'000'000'000, 1000'502'500'000), 7'000'000'000 - 2'500'000);
  // The wall clock stepped back since: the age is unknown, taken as kUnknownAgeNs (stale).
  EXPECT_EQ(ArrivalStamp(rt, 7'000'000'000, 999'000'000'000), 7'000'000'000 - kUnknownAgeNs);
}

}  // namespace
}  // namespace mrd::canbus
