// The local frame bus relay as a process: `mrd-hil serve --port can=PATH` against a relay that
// is alive but stopped with its backlog full (it must refuse the path, not wait in connect()
// forever), and `mrd-canbus` out of file descriptors (it must refuse the nodes it cannot take
// and stay idle, not spin on a readable listener).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "support/process.hpp"

namespace {

using mrd::test::ChildProcess;

const std::string kBin = MRD_BIN_DIR;

std::string SocketPath(const char* tag) {
  return "/tmp/mrd-relay-proc-" + std::string(tag) + "-" + std::to_string(getpid()) + ".sock";
}

// A non-blocking connection to path: the fd, or -errno.
int Connect(const std::string& path) {
  const int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    close(fd);
    return -err;
  }
  return fd;
}

// CPU time a process used so far [s] (utime + stime of /proc/PID/stat).
double CpuSeconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close_paren = text.rfind(')');
  if (close_paren == std::string::npos) return -1.0;
  std::istringstream rest(text.substr(close_paren + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14) utime = std::stoull(field);
    if (i == 15) stime = std::stoull(field);
  }
  return static_cast<double>(utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

TEST(RelayProcess, ServeRefusesARelayThatIsStoppedWithAFullBacklogInsteadOfHanging) {
  const std::string path = SocketPath("stopped");
  unlink(path.c_str());
  ChildProcess relay({kBin + "/mrd-canbus", "--socket", path});
  ASSERT_TRUE(mrd::test::WaitForPath(path, 10.0)) << relay.Stderr();
  relay.Signal(SIGSTOP);
  std::vector<int> nodes;
  int last = 0;
  for (int i = 0; i < 256 && (last = Connect(path)) >= 0; ++i) nodes.push_back(last);
  ASSERT_EQ(last, -EAGAIN) << "the stopped relay's backlog did not fill";

  ChildProcess hil({kBin + "/mrd-hil", "serve", "--port", "can=" + path, "--duration", "1"});
  const int rc = hil.Wait(30.0);
  relay.Signal(SIGCONT);
  for (int fd : nodes) close(fd);
  EXPECT_EQ(rc, 1) << "-1: mrd-hil serve hung in its probe (killed after 30 s)\n" << hil.Stderr();
  EXPECT_NE(hil.Stderr().find("already served"), std::string::npos) << hil.Stderr();
  relay.Signal(SIGTERM);
  EXPECT_EQ(relay.Wait(10.0), 0);
}

TEST(RelayProcess, OutOfDescriptorsTheRelayRefusesNodesAndStaysIdle) {
  const std::string path = SocketPath("emfile");
  unlink(path.c_str());
  // 16 descriptors: stdin/out/err, the listener, a spare, and a handful of nodes.
  ChildProcess relay(
      {"/bin/sh", "-c", "ulimit -n 16 && exec " + kBin + "/mrd-canbus --socket " + path});
  ASSERT_TRUE(mrd::test::WaitForPath(path, 10.0)) << relay.Stderr();
  // 24 nodes; a full backlog (the relay not accepting yet) is retried for a while.
  std::vector<int> nodes;
  int failed = 0;
  for (int i = 0; i < 24; ++i) {
    int fd = -EAGAIN;
    for (int t = 0; t < 300 && fd == -EAGAIN; ++t) {
      fd = Connect(path);
      if (fd == -EAGAIN) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (fd >= 0) {
      nodes.push_back(fd);
    } else {
      ++failed;
    }
  }
  EXPECT_EQ(failed, 0) << "connections that never got past the relay's backlog";
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  // The nodes beyond the limit were refused: closed at once (EOF), not left in the backlog.
  int refused = 0;
  for (int fd : nodes) {
    char b[32];
    if (recv(fd, b, sizeof b, MSG_DONTWAIT) == 0) ++refused;
  }
  EXPECT_GE(refused, 24 - 16 - failed);
  // Idle afterwards: over 1.5 s it uses a small part of a CPU (it spun at ~90 % before).
  const double cpu0 = CpuSeconds(relay.pid());
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const double cpu = CpuSeconds(relay.pid()) - cpu0;
  EXPECT_LT(cpu, 0.3) << "the relay used " << cpu << " s of CPU in 1.5 s idle";
  for (int fd : nodes) close(fd);
  relay.Signal(SIGTERM);
  ASSERT_EQ(relay.Wait(10.0), 0) << relay.Stderr();
  const nlohmann::json j = nlohmann::json::parse(relay.Stdout());
  ASSERT_TRUE(j.contains("nodes_refused")) << j.dump();
  EXPECT_EQ(j["nodes_refused"].get<int>(), refused) << j.dump();
}

}  // namespace
