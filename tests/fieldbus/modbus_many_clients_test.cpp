// `mrd-hil serve`'s Modbus TCP server and descriptors: it must serve sockets numbered beyond
// what a select() fd_set holds (FD_SETSIZE 1024: fd_set overflowed with about 1020 clients,
// and Release aborted), and it limits its clients (32, docs/modbus_registers.md): a client
// beyond the limit is refused at once and counted ("refused" in the port's JSON counters).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "modbus_test_peers.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

constexpr int kClientLimit = 32;     // docs/modbus_registers.md
constexpr int kConnectTimeoutS = 5;  // bounds connect()

// The child has not exited (checked without reaping it).
bool Alive(const ChildProcess& p) {
  siginfo_t si{};
  return waitid(P_PID, static_cast<id_t>(p.pid()), &si, WEXITED | WNOHANG | WNOWAIT) == 0 &&
         si.si_pid == 0;
}

// The server closed the connection within wait_ms.
bool Closed(int fd, int wait_ms) {
  pollfd p{fd, POLLIN, 0};
  if (poll(&p, 1, wait_ms) <= 0) return false;
  char c = 0;
  return recv(fd, &c, 1, MSG_DONTWAIT) == 0;
}

int ReadSensorBlock(int port) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  modbus_set_response_timeout(ctx, 2, 0);
  std::uint16_t regs[13];
  const int n = modbus_connect(ctx) == 0 ? modbus_read_registers(ctx, 0, 13, regs) : -1;
  modbus_close(ctx);
  modbus_free(ctx);
  return n;
}

nlohmann::json Stop(ChildProcess& hil) {
  hil.Signal(SIGTERM);
  EXPECT_EQ(hil.Wait(20.0), 0) << hil.Stderr();
  const nlohmann::json j = nlohmann::json::parse(hil.Stdout(), nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << hil.Stdout() << hil.Stderr();
  return j;
}

// mrd-hil started with 1100 descriptors already open (inherited): its listening socket and
// its clients get numbers above 1023, where select() cannot go.
TEST(ModbusManyClientsTest, ServesSocketsNumberedBeyondFdSetSize) {
  rlimit lim{};
  getrlimit(RLIMIT_NOFILE, &lim);
  if (lim.rlim_cur < 2048 && lim.rlim_max >= 2048) {
    lim.rlim_cur = 2048;
    setrlimit(RLIMIT_NOFILE, &lim);
  }
  ASSERT_GE(lim.rlim_cur, 1200U) << "RLIMIT_NOFILE too low for the test";
  std::vector<int> held;
  for (int i = 0; i < 1100; ++i) held.push_back(open("/dev/null", O_RDONLY));  // inherited
  const int port = FreeTcpPort();
  ChildProcess hil({std::string(MRD_BIN_DIR) + "/mrd-hil", "serve", "--port",
                    "modbus-tcp=127.0.0.1:" + std::to_string(port), "--duration", "60", "--json"});
  for (int fd : held) close(fd);
  ASSERT_TRUE(TcpReady(port, 10.0)) << hil.Stderr();
  std::vector<int> clients;
  for (int i = 0; i < 10; ++i) clients.push_back(ConnectLoopback(port, kConnectTimeoutS));
  EXPECT_EQ(ReadSensorBlock(port), 13) << hil.Stderr();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const bool alive = Alive(hil);
  for (int fd : clients) close(fd);
  ASSERT_TRUE(alive) << "mrd-hil died serving sockets numbered above 1023: " << hil.Stderr();
  Stop(hil);
}

// Idle connections beyond the limit are closed at once and counted; once they are gone, a
// client is served again.
TEST(ModbusManyClientsTest, ClientsBeyondTheLimitAreRefusedAndCounted) {
  const int port = FreeTcpPort();
  ChildProcess hil({std::string(MRD_BIN_DIR) + "/mrd-hil", "serve", "--port",
                    "modbus-tcp=127.0.0.1:" + std::to_string(port), "--duration", "60", "--json"});
  ASSERT_TRUE(TcpReady(port, 10.0)) << hil.Stderr();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the probe has gone
  std::vector<int> clients;
  for (int i = 0; i < kClientLimit + 68; ++i) {
    const int fd = ConnectLoopback(port, kConnectTimeoutS);
    ASSERT_GE(fd, 0) << i;
    clients.push_back(fd);
  }
  // Which connections the server closed, waiting at most 5 s in all.
  std::vector<bool> closed(clients.size(), false);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  int refused = 0;
  while (refused < 68 && std::chrono::steady_clock::now() < until) {
    for (std::size_t i = 0; i < clients.size(); ++i) {
      if (!closed[i] && Closed(clients[i], 0)) {
        closed[i] = true;
        ++refused;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  int first_refused = -1;
  for (std::size_t i = 0; i < closed.size() && first_refused < 0; ++i) {
    if (closed[i]) first_refused = static_cast<int>(i);
  }
  EXPECT_TRUE(first_refused < 0 || first_refused >= kClientLimit - 1) << "refused below the limit";
  EXPECT_GE(refused, 68);
  for (int fd : clients) close(fd);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(ReadSensorBlock(port), 13) << "no client served after the crowd left";
  const nlohmann::json j = Stop(hil);
  EXPECT_GE(j["ports"]["modbus-tcp"]["refused"].get<std::uint64_t>(), 68U) << j["ports"].dump();
}

}  // namespace
}  // namespace mrd::test
