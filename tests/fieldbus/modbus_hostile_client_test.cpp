// mrd-hil's Modbus TCP server (its port, in this process) against hostile clients: the plant
// loop's side (Publish, Poll) never waits for a client, and one client never stalls another.
// A client that never reads its replies, a burst of unknown function codes (libmodbus slept
// 0.5 s before each exception, with the register lock held), a request trickled a byte at a
// time (the server waited for its end).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "modbus_test_peers.hpp"
#include "mrd/hil/ports/plant_port.hpp"

namespace mrd::hil {
namespace {

using Clock = std::chrono::steady_clock;

// A Modbus TCP request: MBAP (transaction, protocol 0, length, unit 1) + PDU.
std::vector<std::uint8_t> Request(std::uint16_t tid, const std::vector<std::uint8_t>& pdu) {
  const std::size_t length = pdu.size() + 1;
  std::vector<std::uint8_t> f(7 + pdu.size());
  f[0] = static_cast<std::uint8_t>(tid >> 8);
  f[1] = static_cast<std::uint8_t>(tid & 0xFF);
  f[4] = static_cast<std::uint8_t>(length >> 8);
  f[5] = static_cast<std::uint8_t>(length & 0xFF);
  f[6] = 1;
  for (std::size_t i = 0; i < pdu.size(); ++i) f[7 + i] = pdu[i];
  return f;
}

SensorOutput Sample(std::uint32_t seq) {
  SensorOutput o;
  o.seq = seq;
  o.sample.v = 1.0;
  return o;
}

// A well-behaved libmodbus client: n reads of the sensor block, each answered within 1 s.
int GoodReads(int port, int n, int gap_ms) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  modbus_set_response_timeout(ctx, 1, 0);
  int ok = 0;
  if (modbus_connect(ctx) == 0) {
    for (int i = 0; i < n; ++i) {
      std::uint16_t regs[13];
      if (modbus_read_registers(ctx, 0, 13, regs) == 13) ++ok;
      std::this_thread::sleep_for(std::chrono::milliseconds(gap_ms));
    }
    modbus_close(ctx);
  }
  modbus_free(ctx);
  return ok;
}

class ModbusHostileClientTest : public ::testing::Test {
 protected:
  void SetUp() override {
    port_ = test::FreeTcpPort();
    port = MakeModbusTcpPort("127.0.0.1:" + std::to_string(port_));
    std::string error;
    ASSERT_TRUE(port->Open(&error)) << error;
    port->Publish(Sample(1));
  }
  void TearDown() override { port->Close(); }
  int port_ = 0;
  std::unique_ptr<PlantPort> port;
};

// The client pipelines reads of the whole map and never reads a reply: the server's output
// to it fills up. The plant's 1000 steps (Publish, Poll) must not wait for that client.
TEST_F(ModbusHostileClientTest, ClientThatNeverReadsDoesNotBlockThePlant) {
  const int hostile = test::ConnectLoopback(port_);
  ASSERT_GE(hostile, 0);
  fcntl(hostile, F_SETFL, fcntl(hostile, F_GETFL) | O_NONBLOCK);
  // Requests until the server stops taking them (its replies are not read) or drops us.
  auto stalled_since = Clock::now();
  for (std::uint32_t i = 0; i < 400'000; ++i) {
    const auto req = Request(static_cast<std::uint16_t>(i), {0x03, 0, 0, 0, 48});
    const ssize_t n = send(hostile, req.data(), req.size(), MSG_NOSIGNAL);
    if (n < 0 && errno == EAGAIN) {
      if (Clock::now() - stalled_since > std::chrono::milliseconds(300)) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      --i;
      continue;
    }
    if (n < 0) break;  // dropped by the server
    stalled_since = Clock::now();
  }
  std::atomic<bool> done{false};
  std::thread plant([&] {
    DriverInput in;
    for (std::uint32_t k = 2; k < 1002; ++k) {
      port->Publish(Sample(k));
      port->Poll(&in);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    done = true;
  });
  const auto until = Clock::now() + std::chrono::seconds(20);
  while (!done && Clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const bool plant_ran = done;
  const int good = GoodReads(port_, 5, 10);  // the server thread is not stuck either
  close(hostile);                            // releases a server blocked on it
  plant.join();
  EXPECT_TRUE(plant_ran) << "the plant's Publish/Poll waited on a client that never reads";
  EXPECT_EQ(good, 5) << "another client was not served";
  EXPECT_GE(port->counters().refused, 1U) << "the client that does not read was not dropped";
}

// Unknown function codes get ILLEGAL FUNCTION at once, not after libmodbus's 0.5 s sleep.
TEST_F(ModbusHostileClientTest, UnknownFunctionCodesAreAnsweredAtOnce) {
  const int c = test::ConnectLoopback(port_);
  ASSERT_GE(c, 0);
  constexpr int kRequests = 20;
  for (int i = 0; i < kRequests; ++i) {
    const auto req = Request(static_cast<std::uint16_t>(i), {0x41, 0, 0});
    ASSERT_EQ(send(c, req.data(), req.size(), MSG_NOSIGNAL), static_cast<ssize_t>(req.size()));
  }
  // 20 replies of 9 bytes (MBAP + 0xC1 + code), within 5 s (the sleeps made it 10 s).
  std::vector<std::uint8_t> in;
  const auto until = Clock::now() + std::chrono::seconds(5);
  while (in.size() < 9U * kRequests && Clock::now() < until) {
    pollfd p{c, POLLIN, 0};
    if (poll(&p, 1, 50) <= 0) continue;
    std::uint8_t buf[512];
    const ssize_t n = read(c, buf, sizeof buf);
    if (n <= 0) break;
    in.insert(in.end(), buf, buf + n);
  }
  close(c);
  ASSERT_EQ(in.size(), 9U * kRequests) << "replies within 5 s";
  for (int i = 0; i < kRequests; ++i) {
    EXPECT_EQ(in[9 * i + 7], 0xC1) << i;
    EXPECT_EQ(in[9 * i + 8], 0x01) << i << ": ILLEGAL FUNCTION";
  }
}

// A request trickled a byte per 100 ms (its header announces 199 bytes of PDU): another
// client's reads are answered meanwhile, and the trickler is dropped once its request has
// been incomplete for longer than the server allows.
TEST_F(ModbusHostileClientTest, TrickledRequestStallsNoOtherClient) {
  const int hostile = test::ConnectLoopback(port_);
  ASSERT_GE(hostile, 0);
  std::atomic<bool> stop{false};
  std::atomic<bool> dropped{false};
  std::thread trickle([&] {
    auto req = Request(1, std::vector<std::uint8_t>(199, 0x03));
    for (std::size_t i = 0; i < req.size() && !stop; ++i) {
      if (send(hostile, &req[i], 1, MSG_NOSIGNAL) != 1) {
        dropped = true;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(150));  // the request has begun
  const int good = GoodReads(port_, 20, 100);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  stop = true;
  trickle.join();
  close(hostile);
  EXPECT_EQ(good, 20) << "a trickled request stalled the other client";
  EXPECT_TRUE(dropped) << "the trickling client was never dropped";
  EXPECT_GE(port->counters().refused, 1U);
}

}  // namespace
}  // namespace mrd::hil
