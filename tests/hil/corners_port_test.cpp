// The four corners of a vehicle as the harness plays them on its own CAN relay
// (MakeCanPortsOnRelay, PublishTick; the shipped canopen-corner-{fl,fr,rl,rr} profiles), with
// the test as the firmware's node on the bus: the relay's one tap reaches every corner's port,
// each port hears only its corner (its command, its status, its drive's NMT and SDO) and the
// firmware's heartbeat, and a tick goes out as every corner's sensor frames then exactly one
// grant.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/frame_codec.hpp"

namespace mrd::hil {
namespace {

namespace pf = profile;
constexpr const char* kCorners[4] = {"fl", "fr", "rl", "rr"};

class CornersPortTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = "/tmp/mrd-hil-corners-" + std::to_string(getpid()) + ".sock";
    std::string error;
    ASSERT_TRUE(relay_.Open(path_, &error)) << error;
    for (const char* c : kCorners) {
      auto p = std::make_shared<pf::CanProfile>();
      const std::string file =
          std::string(MRD_SOURCE_DIR) + "/firmware/profiles/canopen-corner-" + c + ".toml";
      ASSERT_TRUE(pf::LoadCanProfile(file, p.get(), &error)) << error;
      profiles_.push_back(p);
    }
    ports_ = MakeCanPortsOnRelay(relay_, profiles_);
    ASSERT_EQ(ports_.size(), 4U);
    for (auto& p : ports_) {
      ASSERT_TRUE(p->Open(&error)) << error;
      p->SetLockstep(true);
      ptrs_.push_back(p.get());
    }
    const int fd = canbus::OpenLocalBusNode(path_.c_str(), &error);
    ASSERT_GE(fd, 0) << error;
    firmware_.Attach(fd);
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (relay_.nodes() == 0 && std::chrono::steady_clock::now() < until) relay_.Step(1);
    ASSERT_EQ(relay_.nodes(), 1U);
  }
  void TearDown() override {
    firmware_.Close();
    ports_.clear();
    relay_.Close();
  }

  // The firmware sends f; the relay hands it to the ports' tap.
  void FirmwareSend(const can_frame& f) {
    const std::int64_t now = common::MonotonicNs();
    ASSERT_EQ(firmware_.Send(f, now + 1'000'000'000, now), canbus::CanResult::kOk);
    for (int i = 0; i < 20; ++i) relay_.Step(5);
  }
  // A frame of profile p's role r (an output: the firmware's), value v, sealed.
  can_frame Out(int corner, pf::CanOut r, double v) {
    const pf::CanProfile& p = *profiles_[static_cast<std::size_t>(corner)];
    pf::FrameCodec codec(p);
    const pf::SignalRef ref = p.outputs[static_cast<std::size_t>(r)];
    can_frame f{};
    codec.Begin(ref.message, &f);
    EXPECT_EQ(codec.Set(&f, ref, v), protocol::SignalError::kNone);
    codec.Seal(ref.message, &f);
    return f;
  }
  std::vector<DriverInput> PollAll() {
    std::vector<DriverInput> in(4);
    for (std::size_t i = 0; i < 4; ++i) ports_[i]->Poll(&in[i]);
    return in;
  }
  // Every frame the firmware's node has received so far.
  std::vector<can_frame> Drain() {
    std::vector<can_frame> out;
    for (int idle = 0; idle < 50;) {
      can_frame f{};
      std::int64_t stamp = 0;
      if (firmware_.Receive(&f, &stamp) == canbus::CanResult::kOk) {
        out.push_back(f);
        idle = 0;
      } else {
        ++idle;
        usleep(1000);
      }
    }
    return out;
  }

  std::string path_;
  canbus::LocalBusRelay relay_;
  std::vector<std::shared_ptr<const pf::CanProfile>> profiles_;
  std::vector<std::unique_ptr<PlantPort>> ports_;
  std::vector<PlantPort*> ptrs_;
  canbus::CanIface firmware_;
};

TEST_F(CornersPortTest, EachCornersPortHearsOnlyItsCommandAndStatusAndEveryOneTheHeartbeat) {
  for (int corner = 0; corner < 4; ++corner) {
    // The firmware's heartbeat, then the corner's command (1000 mA) and its status (a tick
    // ends with the status: lockstep Poll stops there).
    can_frame hb{};
    hb.can_id = 0x701;
    hb.len = 1;
    hb.data[0] = 0x05;  // operational
    FirmwareSend(hb);
    FirmwareSend(Out(corner, pf::CanOut::kCommand, 1000.0));
    FirmwareSend(Out(corner, pf::CanOut::kStatusCauses, 3.0));
    const std::vector<DriverInput> in = PollAll();
    for (int i = 0; i < 4; ++i) {
      const DriverInput& d = in[static_cast<std::size_t>(i)];
      EXPECT_EQ(d.has_command, i == corner) << "corner " << corner << ", port " << i;
      EXPECT_EQ(d.has_status, i == corner) << "corner " << corner << ", port " << i;
      EXPECT_EQ(d.heartbeats, 1U) << "every drive watches the firmware's heartbeat";
      if (i == corner) {
        EXPECT_NEAR(d.volts, profiles_[static_cast<std::size_t>(i)]->command.Invert(1000.0), 1e-12);
        EXPECT_EQ(d.status_causes, 3U);
      }
    }
  }
  for (const auto& p : ports_) EXPECT_EQ(p->counters().rejected, 0U);
}

TEST_F(CornersPortTest, EachCornersDriveAnswersOnlyItsOwnNmtAndSdo) {
  // NMT start for node 6 (front-right) only: its drive goes operational and heartbeats.
  can_frame nmt{};
  nmt.can_id = 0x000;
  nmt.len = 2;
  nmt.data[0] = 0x01;
  nmt.data[1] = 6;
  FirmwareSend(nmt);
  // An SDO download to node 7 (rear-left): 0x1017 = 10 ms.
  can_frame sdo{};
  sdo.can_id = 0x600 + 7;
  sdo.len = 8;
  sdo.data[0] = 0x2B;  // expedited, 2 bytes
  sdo.data[1] = 0x17;
  sdo.data[2] = 0x10;
  sdo.data[3] = 0;
  sdo.data[4] = 10;
  FirmwareSend(sdo);
  (void)PollAll();  // the drives handle them
  for (int i = 0; i < 20; ++i) relay_.Step(5);
  std::vector<SensorOutput> outs(4);
  for (int k = 0; k < 10; ++k) {  // the default producer period: 10 steps
    for (auto& o : outs) o.seq = static_cast<std::uint32_t>(k + 1);
    PublishTick(ptrs_, outs, (k + 1) * 1'000'000);
  }
  int sdo_answers = 0, heartbeats = 0;
  for (const can_frame& f : Drain()) {
    const canid_t id = f.can_id & CAN_SFF_MASK;
    if (id >= 0x580 && id < 0x600) {
      EXPECT_EQ(id, 0x580U + 7) << "only node 7 answers its SDO";
      ++sdo_answers;
    }
    if (id >= 0x700 && id < 0x780) {
      EXPECT_EQ(id, 0x700U + 6) << "only the started drive (node 6) produces a heartbeat";
      ++heartbeats;
    }
  }
  EXPECT_EQ(sdo_answers, 1);
  EXPECT_EQ(heartbeats, 1);
}

TEST_F(CornersPortTest, ATickIsEveryCornersSensorFramesThenExactlyOneGrant) {
  std::vector<SensorOutput> outs(4);
  constexpr int kTicks = 5;
  for (int k = 0; k < kTicks; ++k) {
    for (std::size_t i = 0; i < 4; ++i) {
      outs[i].seq = static_cast<std::uint32_t>(k + 1);
      outs[i].sample.v = 1.0 + static_cast<double>(i);
    }
    PublishTick(ptrs_, outs, (k + 1) * 1'000'000);
  }
  const std::vector<can_frame> frames = Drain();
  // Per tick: SensorTpdo1 and SensorTpdo2 of nodes 16..19 (0x190.., 0x290..), then 0x7F0.
  int grants = 0, sensors_since_grant = 0;
  for (const can_frame& f : frames) {
    const canid_t id = f.can_id & CAN_SFF_MASK;
    if (id == 0x7F0) {
      EXPECT_EQ(sensors_since_grant, 8) << "tick " << grants << ": four corners' two frames";
      const std::uint64_t us = static_cast<std::uint64_t>(f.data[0]) |
                               static_cast<std::uint64_t>(f.data[1]) << 8 |
                               static_cast<std::uint64_t>(f.data[2]) << 16;
      EXPECT_EQ(us, static_cast<std::uint64_t>(grants + 1) * 1000U);
      ++grants;
      sensors_since_grant = 0;
    } else if ((id >= 0x190 && id <= 0x193) || (id >= 0x290 && id <= 0x293)) {
      ++sensors_since_grant;
    }
  }
  EXPECT_EQ(grants, kTicks);
  EXPECT_EQ(sensors_since_grant, 0) << "no sensor frame after the last grant";
  for (const auto& p : ports_) EXPECT_EQ(p->counters().published, static_cast<unsigned>(kTicks));
}

}  // namespace
}  // namespace mrd::hil
