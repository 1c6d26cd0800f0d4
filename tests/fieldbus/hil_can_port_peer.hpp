#pragma once
// The harness's CAN port on a local bus it owns (nobody else serves the socket), with the test
// as the firmware's node on that bus: a gtest fixture for the port tests and the harness's CAN
// conformance tests.

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::hil {

class HilCanPortPeerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = "/tmp/mrd-hil-can-port-" + std::to_string(getpid()) + ".sock";
    port_ = MakeCanPort(path_);
    ASSERT_NE(port_, nullptr);
    std::string error;
    ASSERT_TRUE(port_->Open(&error)) << error;  // nobody serves: the port owns the bus
    const int fd = canbus::OpenLocalBusNode(path_.c_str(), &error);
    ASSERT_GE(fd, 0) << error;
    firmware_.Attach(fd);
    // Once the port hears a status frame from this node, the relay has accepted it (and
    // frames published from now on reach it).
    can_frame status{};
    ASSERT_EQ(protocol::can::Encode(protocol::can::FirmwareStatus{}, &status),
              protocol::can::Reject::kNone);
    FirmwareSend(status);
    DriverInput in;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (port_->counters().received == 0 && std::chrono::steady_clock::now() < until) {
      port_->Poll(&in);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    ASSERT_EQ(port_->counters().received, 1U);
  }
  void TearDown() override {
    firmware_.Close();
    if (port_ != nullptr) port_->Close();
  }
  void FirmwareSend(const can_frame& f) {
    const std::int64_t now = common::MonotonicNs();
    ASSERT_EQ(firmware_.Send(f, now + 1'000'000'000, now), canbus::CanResult::kOk);
  }
  void Command(double volts, std::uint16_t echo, std::uint8_t counter) {
    can_frame f{};
    ASSERT_EQ(protocol::can::Encode(
                  protocol::can::DriverCommand{volts, true, true, false, echo, counter}, &f),
              protocol::can::Reject::kNone);
    FirmwareSend(f);
  }
  // Polls until something arrived (or 1 s).
  DriverInput PollSome() {
    DriverInput in;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    while (std::chrono::steady_clock::now() < until) {
      port_->Poll(&in);
      if (in.has_command || in.heartbeat_ns != 0) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    port_->Poll(&in);  // whatever else was sent with it
    return in;
  }

  std::string path_;
  std::unique_ptr<PlantPort> port_;
  canbus::CanIface firmware_;
};

}  // namespace mrd::hil
