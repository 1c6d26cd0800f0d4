// The harness's CAN port: it owns the local bus when nobody serves it, publishes sensor
// frames, hears commands and heartbeats, rejects bad frames, and expands the 16-bit sensor
// echo to the step number across the wrap.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>

#include "hil_can_port_peer.hpp"
#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::hil {
namespace {

namespace pc = protocol::can;

class HilCanPortTest : public HilCanPortPeerTest {};

TEST_F(HilCanPortTest, PublishesSensorFramesWithSeqAndCounters) {
  SensorOutput out;
  out.sample.v = 10.5;
  out.sample.x = -0.25;
  out.sample.demand = 900.0;
  out.sample.body_velocity = 2.0;
  out.sample.force = 850.5;
  out.seq = 70001;  // beyond 16 bits: the frame carries the low 16
  port_->Publish(out);
  out.seq = 70002;
  port_->Publish(out);
  pc::SensorMotion m[2];
  int motions = 0, forces = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (std::chrono::steady_clock::now() < until && (motions < 2 || forces < 2)) {
    can_frame f{};
    std::int64_t stamp = 0;
    if (firmware_.Receive(&f, &stamp) != canbus::CanResult::kOk) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    pc::SensorForce sf;
    if (motions < 2 && pc::Decode(f, &m[motions]) == pc::Reject::kNone) ++motions;
    if (pc::Decode(f, &sf) == pc::Reject::kNone) {
      ++forces;
      EXPECT_DOUBLE_EQ(sf.force, 850.5);
    }
  }
  ASSERT_EQ(motions, 2);
  EXPECT_EQ(forces, 2);
  EXPECT_DOUBLE_EQ(m[0].velocity, 10.5);
  EXPECT_DOUBLE_EQ(m[0].displacement, -0.25);
  EXPECT_EQ(m[0].seq, 70001 & 0xFFFF);
  EXPECT_EQ(m[1].counter, (m[0].counter + 1) & 15);
  EXPECT_EQ(port_->counters().published, 2U);
}

TEST_F(HilCanPortTest, HearsCommandEnableHeartbeatAndExpandsTheEchoAcrossTheWrap) {
  SensorOutput out;
  out.seq = 65537;  // published 0x10001; the firmware echoes 0xFFFF (step 65535)
  port_->Publish(out);
  Command(1.25, 0xFFFF, 0);
  can_frame hb{};
  ASSERT_EQ(pc::Encode(pc::Heartbeat{false, 0}, &hb), pc::Reject::kNone);
  FirmwareSend(hb);
  DriverInput in = PollSome();
  ASSERT_TRUE(in.has_command);
  EXPECT_DOUBLE_EQ(in.volts, 1.25);
  EXPECT_TRUE(in.has_enable);
  EXPECT_TRUE(in.enable);
  ASSERT_TRUE(in.has_echo);
  EXPECT_EQ(in.echo, 65535U);
  EXPECT_GT(in.heartbeat_ns, 0);
  EXPECT_GT(in.command_ns, 0);

  Command(1.0, 0x0001, 1);  // echo of the latest step, 0x10001
  in = PollSome();
  EXPECT_EQ(in.echo, 65537U);
  EXPECT_EQ(port_->counters().received, 1U + 3U);  // status, command, heartbeat, command
  EXPECT_EQ(port_->counters().rejected, 0U);
}

TEST_F(HilCanPortTest, RejectsBadFramesFromTheFirmware) {
  can_frame f{};
  ASSERT_EQ(pc::Encode(pc::DriverCommand{1.0, true, true, false, 1, 5}, &f), pc::Reject::kNone);
  can_frame bad_crc = f;
  bad_crc.data[0] ^= 1;
  FirmwareSend(bad_crc);
  can_frame unknown = f;
  unknown.can_id = 0x7AB;
  FirmwareSend(unknown);
  FirmwareSend(f);  // accepted
  FirmwareSend(f);  // repeated counter
  DriverInput in = PollSome();
  EXPECT_TRUE(in.has_command);
  EXPECT_EQ(port_->counters().received, 1U + 1U);  // the status of SetUp, one command
  EXPECT_EQ(port_->counters().rejected, 3U);
}

TEST(HilCanPort, AnUnusableEndpointIsAClearError) {
  std::string error;
  auto port = MakeCanPort("/nonexistent-dir/bus.sock");
  ASSERT_NE(port, nullptr);
  EXPECT_FALSE(port->Open(&error));
  EXPECT_NE(error.find("/nonexistent-dir/bus.sock"), std::string::npos) << error;
  auto board = MakeCanPort("mrdcan9");
  EXPECT_FALSE(board->Open(&error));
  EXPECT_NE(error.find("mrdcan9"), std::string::npos) << error;
}

}  // namespace
}  // namespace mrd::hil
