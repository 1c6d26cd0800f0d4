#pragma once
// The firmware's CAN device with the test as its peer on the other end of a SOCK_SEQPACKET
// socketpair (the same fd code as the local frame bus and SocketCAN): a gtest fixture for the
// device tests and the device's conformance tests.

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/protocol/can_codec.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {

// Every input and output routed to CAN.
inline CanConfig AllRouted() {
  CanConfig c;
  c.enabled = true;
  c.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand) |
             Bit(Input::kBodyVelocity) | Bit(Input::kForce);
  c.outputs =
      Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat) | Bit(Output::kStatus);
  return c;
}

// A configured, active device (AllRouted, or Make's config) and its peer's descriptor.
class CanDevicePeerTest : public ::testing::Test {
 protected:
  void SetUp() override { Make(AllRouted()); }
  void TearDown() override {
    device_.reset();
    if (peer_ >= 0) close(peer_);
  }
  void Make(const CanConfig& config) {
    device_.reset();
    if (peer_ >= 0) close(peer_);
    int sv[2];
    ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
    peer_ = sv[1];
    device_ = std::make_unique<CanDevice>(config, sv[0]);
    std::string error;
    ASSERT_TRUE(device_->Configure(&error)) << error;
    ASSERT_TRUE(device_->Activate(&error)) << error;
  }
  void PeerSend(const can_frame& f) {
    ASSERT_EQ(write(peer_, &f, sizeof f), static_cast<ssize_t>(sizeof f));
  }
  void SendMotion(double v, double x, std::uint16_t seq, std::uint8_t counter) {
    can_frame f{};
    ASSERT_EQ(protocol::can::Encode(protocol::can::SensorMotion{v, x, seq, counter}, &f),
              protocol::can::Reject::kNone);
    PeerSend(f);
  }
  // Frames the device sent, in order.
  std::vector<can_frame> PeerDrain() {
    std::vector<can_frame> out;
    can_frame f{};
    while (recv(peer_, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) {
      out.push_back(f);
    }
    return out;
  }
  IoStatus Read(SensorFrame* frame, IoError* why = nullptr) {
    IoError w = IoError::kNone;
    const IoStatus s = device_->Read(::mrd::test::NowIo(), frame, &w);
    if (why != nullptr) *why = w;
    return s;
  }
  std::uint64_t Errors(IoError e) const {
    return device_->counters().errors[static_cast<std::size_t>(e)];
  }

  // Counts heartbeat and status frames the device sent; keeps the last status.
  void PeerDrainInto() {
    for (const can_frame& f : PeerDrain()) {
      protocol::can::Heartbeat hb;
      protocol::can::FirmwareStatus st;
      if (protocol::can::Decode(f, &hb) == protocol::can::Reject::kNone) ++heartbeats_;
      if (protocol::can::Decode(f, &st) == protocol::can::Reject::kNone) {
        ++statuses_;
        last_status_ = st;
      }
    }
  }

  std::unique_ptr<CanDevice> device_;
  int peer_ = -1;
  int heartbeats_ = 0, statuses_ = 0;
  protocol::can::FirmwareStatus last_status_;
};

}  // namespace mrd::firmware
