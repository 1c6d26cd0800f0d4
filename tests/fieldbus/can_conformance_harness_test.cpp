// Conformance of the harness's CAN side (docs/can_bus.md, docs/mrd.dbc): the simulated driver
// sends DriverStatus at its documented period with its current and fault bits, and a babbling
// node on the harness's own relay does not crowd the firmware's commands out of its queue.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "hil_can_port_peer.hpp"
#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::hil {
namespace {

namespace pc = protocol::can;

class HilCanPortConformance : public HilCanPortPeerTest {};

TEST_F(HilCanPortConformance, TheSimulatedDriverSendsDriverStatusWithItsCurrentAndFaults) {
  // Statuses the firmware's node hears, in order.
  std::vector<pc::DriverStatus> statuses;
  const auto drain = [&] {
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(200);
    while (std::chrono::steady_clock::now() < until) {
      can_frame f{};
      std::int64_t stamp = 0;
      if (firmware_.Receive(&f, &stamp) != canbus::CanResult::kOk) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      pc::DriverStatus st;
      if (pc::Decode(f, &st) == pc::Reject::kNone) statuses.push_back(st);
    }
  };
  SensorOutput out;
  out.seq = 1;
  port_->Publish(out);  // the first step: a status at once, idle (no command yet: 0 A)
  drain();
  ASSERT_EQ(statuses.size(), 1U);
  EXPECT_EQ(statuses[0].faults, 0);
  EXPECT_DOUBLE_EQ(statuses[0].current, 0.0);
  // A command enabling the coil at 2 V: the next periodic status reports 2 V / 5 ohm.
  Command(2.0, 1, 0);
  PollSome();
  for (std::uint32_t k = 2; k <= 100; ++k) {
    out.seq = k;
    port_->Publish(out);
  }
  drain();
  ASSERT_EQ(statuses.size(), 1U) << "one status per 100 steps";
  out.seq = 101;
  port_->Publish(out);
  drain();
  ASSERT_EQ(statuses.size(), 2U);
  EXPECT_NEAR(statuses[1].current, 0.4, 1e-9);
  EXPECT_EQ(statuses[1].counter, (statuses[0].counter + 1) & 15);
  // The driver's fault (the fault line of the step) goes out at once, as overcurrent, and its
  // end too.
  out.seq = 102;
  out.fault_line = true;
  port_->Publish(out);
  out.seq = 103;
  port_->Publish(out);
  out.seq = 104;
  out.fault_line = false;
  port_->Publish(out);
  drain();
  ASSERT_EQ(statuses.size(), 4U);
  EXPECT_EQ(statuses[2].faults, pc::kFaultOvercurrent);
  EXPECT_EQ(statuses[3].faults, 0);
}

// mrd-hil run's port: an in-process node of the relay the harness owns. Frames of IDs the
// harness does not listen to (a babbling node's) never fill its queue, so the firmware's
// commands still get through.
TEST(HilCanPortOnRelay, ABabblingNodeDoesNotCrowdOutTheFirmwaresCommands) {
  const std::string path = "/tmp/mrd-hil-can-relay-" + std::to_string(getpid()) + ".sock";
  canbus::LocalBusRelay relay;
  std::string error;
  ASSERT_TRUE(relay.Open(path, &error)) << error;
  auto port = MakeCanPortOnRelay(relay);
  ASSERT_TRUE(port->Open(&error)) << error;
  const int babbler = canbus::OpenLocalBusNode(path.c_str(), &error);
  ASSERT_GE(babbler, 0) << error;
  canbus::CanIface firmware;
  firmware.Attach(canbus::OpenLocalBusNode(path.c_str(), &error));
  ASSERT_TRUE(firmware.is_open()) << error;
  for (int i = 0; i < 20 && relay.nodes() < 2; ++i) relay.Step(5);
  ASSERT_EQ(relay.nodes(), 2U);
  can_frame junk{};
  ASSERT_EQ(pc::Encode(pc::SensorMotion{1.0, 0.0, 1, 0}, &junk), pc::Reject::kNone);
  junk.data[7] ^= 0x5A;  // bad checksum
  for (int i = 0; i < 270; ++i) {
    ASSERT_EQ(send(babbler, &junk, sizeof junk, MSG_DONTWAIT), static_cast<ssize_t>(sizeof junk));
  }
  for (int i = 0; i < 10; ++i) relay.Step(5);  // the harness busy elsewhere: no Poll yet
  can_frame cmd{};
  ASSERT_EQ(pc::Encode(pc::DriverCommand{1.0, true, true, false, 1, 0}, &cmd), pc::Reject::kNone);
  const std::int64_t now = common::MonotonicNs();
  ASSERT_EQ(firmware.Send(cmd, now + 1'000'000'000, now), canbus::CanResult::kOk);
  for (int i = 0; i < 5; ++i) relay.Step(5);
  DriverInput in;
  for (int i = 0; i < 10; ++i) port->Poll(&in);
  EXPECT_TRUE(in.has_command);
  EXPECT_EQ(port->counters().received, 1U);
  close(babbler);
  firmware.Close();
  port->Close();
  relay.Close();
}

}  // namespace
}  // namespace mrd::hil
