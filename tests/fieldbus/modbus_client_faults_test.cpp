// The firmware's Modbus client (ModbusDevice over TCP) against scripted misbehaving servers
// (modbus_raw_peer.hpp, framed by hand from the Modbus TCP guide): replies with another unit
// id or a non-zero MBAP protocol id are refused (rejected_frame, docs/modbus_registers.md);
// a protocol-level bad value keeps a good connection; a peer that resets every connection
// gets the documented backoff; late and trickled replies never deliver data stamped fresher
// than the request that fetched them.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "modbus_raw_peer.hpp"
#include "modbus_test_peers.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

using test::WaitFor;

ModbusConfig TcpConfig(int port) {
  ModbusConfig c;
  c.enabled = true;
  c.mode = ModbusMode::kTcp;
  c.host = "127.0.0.1";
  c.port = port;
  c.slave = 1;
  c.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kFaultLine);
  c.outputs = Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat);
  c.response_timeout_ns = 20'000'000;
  c.retries = 1;
  return c;
}

class ModbusClientFaultsTest : public ::testing::Test {
 protected:
  // A raw peer playing `script` on a free port, and the device (TcpConfig) active against it.
  void Start(const test::RawPeerScript& script) {
    const int port = test::FreeTcpPort();
    peer_ = std::make_unique<test::RawTcpPeer>(port, script);
    ASSERT_TRUE(peer_->listening());
    device_ = std::make_unique<ModbusDevice>(TcpConfig(port));
    std::string error;
    ASSERT_TRUE(device_->Configure(&error) && device_->Activate(&error)) << error;
  }
  std::uint64_t Errors(IoError e) const { return device_->counters().errors[static_cast<int>(e)]; }

  std::unique_ptr<test::RawTcpPeer> peer_;  // outlives the device, as a server does
  std::unique_ptr<ModbusDevice> device_;
};

// A reply is the server's only if it carries the unit id the request addressed: Modbus TCP
// carries it in the MBAP header, and libmodbus 3.1.6 never checked it there.
TEST_F(ModbusClientFaultsTest, ReplyFromAnotherUnitIdIsARejectedFrame) {
  ASSERT_NO_FATAL_FAILURE(Start({.reply_unit = 2}));  // the device addresses unit 1
  ASSERT_TRUE(WaitFor([&] { return Errors(IoError::kRejectedFrame) >= 5; }, 5.0))
      << "rx_ok " << device_->counters().rx_ok;
  SensorFrame f;
  IoError why = IoError::kNone;
  EXPECT_EQ(device_->Read(::mrd::test::NowIo(), &f, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kRejectedFrame);
  device_->Deactivate();
  const DeviceCounters c = device_->counters();
  EXPECT_EQ(c.rx_ok, 0U);
  EXPECT_GE(c.rx_rejected, 5U);
  EXPECT_EQ(c.reconnects, 0U);  // the frames were well formed: the link stays
  EXPECT_EQ(peer_->accepts(), 1);
}

TEST_F(ModbusClientFaultsTest, ReplyWithAProtocolIdOtherThanZeroIsARejectedFrame) {
  // libmodbus 3.1.6 accepted it (it tests hi != 0 && lo != 0)
  ASSERT_NO_FATAL_FAILURE(Start({.reply_protocol = 7}));
  ASSERT_TRUE(WaitFor([&] { return Errors(IoError::kRejectedFrame) >= 5; }, 5.0))
      << "rx_ok " << device_->counters().rx_ok;
  device_->Deactivate();
  EXPECT_EQ(device_->counters().rx_ok, 0U);
  EXPECT_EQ(device_->counters().reconnects, 0U);
}

// A reserved fault bit is a bad value in a well-formed reply: the data are refused
// (bad_value, the loop goes safe), but the link that carried it is fine and is kept.
TEST_F(ModbusClientFaultsTest, BadValueKeepsTheConnection) {
  ASSERT_NO_FATAL_FAILURE(Start({.faults = 0x0080}));
  ASSERT_TRUE(WaitFor([&] { return peer_->reads() >= 300; }, 20.0)) << peer_->reads();
  SensorFrame f;
  IoError why = IoError::kNone;
  EXPECT_EQ(device_->Read(::mrd::test::NowIo(), &f, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kBadValue);
  device_->Deactivate();
  EXPECT_GE(Errors(IoError::kBadValue), 250U);
  EXPECT_EQ(device_->counters().rx_ok, 0U);
  EXPECT_EQ(device_->counters().reconnects, 0U);
  EXPECT_EQ(peer_->accepts(), 1) << "a good connection was dropped and reopened for a bad value";
}

// A peer that accepts and at once resets: every failed session is followed by the backoff
// (5 ms doubling to 200 ms: about 9 connections in the first second), not a reconnect storm.
TEST_F(ModbusClientFaultsTest, PeerThatResetsEveryConnectionGetsTheBackoff) {
  ASSERT_NO_FATAL_FAILURE(Start({.reset_on_accept = true}));
  std::this_thread::sleep_for(std::chrono::seconds(1));
  device_->Deactivate();
  std::printf("connections accepted and reset in 1 s: %d\n", peer_->accepts());
  // A loaded machine only makes the count smaller; the storm was ~2900 per second.
  EXPECT_LE(peer_->accepts(), 20);
  EXPECT_GE(peer_->accepts(), 2);
  EXPECT_GT(Errors(IoError::kDisconnected), 0U);
  EXPECT_EQ(device_->counters().rx_ok, 0U);
}

// The seq of a sample: the raw peer sets velocity = seq x 1e-4 cm/s.
std::uint32_t SeqOf(const SensorFrame& f) {
  return static_cast<std::uint32_t>(std::llround(f[Input::kVelocity].value / 1e-4));
}

// Replies 15 ms late (inside the 20 ms timeout): the values are as old as the request that
// fetched them, so their stamp is no later than the request's arrival at the server.
TEST_F(ModbusClientFaultsTest, LateReplyIsStampedWithItsRequest) {
  ASSERT_NO_FATAL_FAILURE(Start({.reply_delay_ms = 15}));
  int fresh = 0;
  ASSERT_TRUE(WaitFor(
      [&] {
        SensorFrame f;
        IoError why = IoError::kNone;
        if (device_->Read(::mrd::test::NowIo(), &f, &why) == IoStatus::kOk) {
          const std::uint32_t seq = SeqOf(f);
          const std::int64_t arrival = peer_->ReadArrival(seq);
          EXPECT_GT(arrival, 0) << "seq " << seq;
          EXPECT_LE(f[Input::kVelocity].stamp_ns, arrival)
              << "seq " << seq << " stamped " << (f[Input::kVelocity].stamp_ns - arrival) / 1000
              << " us after its request reached the server";
          ++fresh;
        }
        return fresh >= 5;
      },
      10.0));
  device_->Deactivate();
}

// A reply trickled a byte per 15 ms takes ~0.5 s; no byte gap reaches the timeout, but the
// reply is not complete within it: a timeout, never a sample (and no sample stamped after
// its request).
TEST_F(ModbusClientFaultsTest, TrickledReplyIsNeverDeliveredAsFresh) {
  ASSERT_NO_FATAL_FAILURE(Start({.trickle_ms = 15}));
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(2500);
  while (std::chrono::steady_clock::now() < until) {
    SensorFrame f;
    IoError why = IoError::kNone;
    if (device_->Read(::mrd::test::NowIo(), &f, &why) == IoStatus::kOk) {
      const std::uint32_t seq = SeqOf(f);
      EXPECT_LE(f[Input::kVelocity].stamp_ns, peer_->ReadArrival(seq))
          << "seq " << seq << " delivered as fresh "
          << (f[Input::kVelocity].stamp_ns - peer_->ReadArrival(seq)) / 1'000'000
          << " ms after its request reached the server";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  device_->Deactivate();
  EXPECT_GT(Errors(IoError::kTimeout), 0U);
  EXPECT_GE(peer_->reads(), 1);
}

}  // namespace
}  // namespace mrd::firmware
