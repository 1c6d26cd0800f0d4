// Issue 11 (label cross): systemd notifications over a plain AF_UNIX datagram socket.
#include "mrd/firmware/platform/sd_notify.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <string>

#include "host/test_util.hpp"

namespace mrd::firmware {
namespace {

// Receives one datagram without blocking; "" when none is queued.
std::string Receive(int fd) {
  char buf[256];
  const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
  return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
}

TEST(SystemdNotifierTest, SendsReadyAndPingsOnlyWhileTicksAdvance) {
  test::TempDir dir;
  const std::string path = dir.File("notify");
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  ASSERT_LT(path.size(), sizeof addr.sun_path);
  std::memcpy(addr.sun_path, path.c_str(), path.size());
  ASSERT_EQ(::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0);
  ::setenv("NOTIFY_SOCKET", path.c_str(), 1);
  ::setenv("WATCHDOG_USEC", "200000", 1);  // 200 ms: ping every 100 ms
  platform::SystemdNotifier n;
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  ASSERT_TRUE(n.enabled());
  EXPECT_EQ(n.watchdog_interval_ns(), 100'000'000);
  EXPECT_TRUE(n.Send("READY=1"));
  EXPECT_EQ(Receive(fd), "READY=1");
  n.Ping(200'000'000, 10);
  EXPECT_EQ(Receive(fd), "WATCHDOG=1");
  n.Ping(250'000'000, 20);  // too soon
  EXPECT_EQ(Receive(fd), "");
  n.Ping(400'000'000, 20);
  EXPECT_EQ(Receive(fd), "WATCHDOG=1");
  n.Ping(600'000'000, 20);  // loop stalled: no ping, systemd's watchdog fires
  EXPECT_EQ(Receive(fd), "");
  ::close(fd);
}

TEST(SystemdNotifierTest, WithoutNotifySocketNothingIsSent) {
  ::unsetenv("NOTIFY_SOCKET");
  platform::SystemdNotifier n;
  EXPECT_FALSE(n.enabled());
  EXPECT_FALSE(n.Send("READY=1"));
  n.Ping(1'000'000'000, 1);
}

}  // namespace
}  // namespace mrd::firmware
