#pragma once
// The test's side of a four-corner CANopen vehicle on one CAN bus (the shipped
// canopen-corner-{fl,fr,rl,rr} profiles): the four drives (SDO answers, NMT start, heartbeats,
// status TPDOs) and sensor nodes played with the profiles' codecs, per step each corner's
// sensor frames then one grant, and each corner's command read back. The bus: the local frame
// bus relay in-process (the test its in-process node), or another transport (Bus).
#include <gtest/gtest.h>
#include <linux/can.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "mrd/canbus/local_bus.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/canopen_codec.hpp"
#include "mrd/profile/frame_codec.hpp"

namespace mrd::test::corners {

namespace co = profile::canopen;
namespace pf = profile;

constexpr std::size_t kCorners = 4;
constexpr const char* kCornerNames[kCorners] = {"fl", "fr", "rl", "rr"};

inline std::string CornerProfilePath(std::size_t i) {
  return std::string(MRD_SOURCE_DIR) + "/firmware/profiles/canopen-corner-" + kCornerNames[i] +
         ".toml";
}

inline std::shared_ptr<const pf::CanProfile> CornerProfile(std::size_t i) {
  auto p = std::make_shared<pf::CanProfile>();
  std::string error;
  const std::string path = CornerProfilePath(i);
  EXPECT_TRUE(pf::LoadCanProfile(path, p.get(), &error)) << error;
  return p;
}

// How the test's frames reach the firmware's nodes.
class Bus {
 public:
  virtual ~Bus() = default;
  // A frame to every node (a step's: queued until EndStep).
  virtual void Send(const can_frame& f) = 0;
  virtual void BeginStep(int /*step*/) {}
  virtual void EndStep() {}
  // Waits up to timeout_ms; appends the frames the firmware's nodes sent.
  virtual void Poll(int timeout_ms, std::vector<can_frame>* got) = 0;
};

// The local frame bus relay in-process: the test is its in-process node.
class RelayBus final : public Bus {
 public:
  RelayBus() {
    path_ = "/tmp/mrd-channels-test-" + std::to_string(getpid()) + ".sock";
    std::string error;
    EXPECT_TRUE(relay_.Open(path_, &error)) << error;
    relay_.SetTap(
        [](void* self, const void* frame, std::int64_t) {
          static_cast<RelayBus*>(self)->tapped_->push_back(*static_cast<const can_frame*>(frame));
        },
        this);
  }
  const std::string& path() const { return path_; }
  void Send(const can_frame& f) override { relay_.Broadcast(&f); }
  void BeginStep(int) override { relay_.Hold(); }
  void EndStep() override { relay_.Release(); }
  void Poll(int timeout_ms, std::vector<can_frame>* got) override {
    tapped_ = got;
    (void)relay_.Step(timeout_ms);
  }

 private:
  canbus::LocalBusRelay relay_;
  std::string path_;
  std::vector<can_frame>* tapped_ = nullptr;
};

// One corner's command in a step: the set-point [mA] and the enable bit.
struct Command {
  double current_ma = NAN;
  double enable = NAN;
  bool operator==(const Command& o) const {
    return std::memcmp(this, &o, sizeof o) == 0;  // bit for bit
  }
};
using Step = std::array<Command, kCorners>;

struct Scenario {
  firmware::FaultPolicy policy = firmware::FaultPolicy::kAll;
  int steps = 400;
  int silent_corner = -1;  // from silent_from on, this corner's sensor frames stop
  int silent_from = 0;
  int late_ms = -1;  // >= 0: LateFollowersBus (2 ms, and late_ms once at step 100)
};

// Corner i's motion and demand at step k: every corner's own (a velocity 10 um/s apart per
// corner, a damping demand c_i v with c_i growing with i: corner i's demand is the larger).
inline double Velocity(std::size_t i, int k) {  // [cm/s]
  return 12.0 * std::sin(2.0 * M_PI * k / 250.0) + 1e-3 * static_cast<double>(i);
}
inline double Demand(std::size_t i, int k) {  // [N]
  return (50.0 + 10.0 * static_cast<double>(i)) * Velocity(i, k);
}

// The drives and sensor nodes: the test's side of the bus.
class Vehicle {
 public:
  explicit Vehicle(const std::array<std::shared_ptr<const pf::CanProfile>, 4>& profiles) {
    for (std::size_t i = 0; i < kCorners; ++i) {
      profiles_[i] = profiles[i];
      codecs_[i] = std::make_unique<pf::FrameCodec>(*profiles[i]);
    }
  }
  // The firmware's frame f during start-up: SDO answered, NMT start noted. True when every
  // drive has been started.
  bool StartUp(Bus& bus, const can_frame& f) {
    const std::uint32_t id = f.can_id & CAN_SFF_MASK;
    for (std::size_t i = 0; i < kCorners; ++i) {
      const int node = profiles_[i]->canopen->node_id;
      if (id == co::SdoRequestId(node)) {
        can_frame a{};
        a.can_id = co::SdoResponseId(node);
        a.len = 8;
        a.data[0] = 0x60;  // download confirmed
        a.data[1] = f.data[1];
        a.data[2] = f.data[2];
        a.data[3] = f.data[3];
        bus.Send(a);
      }
      if (id == co::kNmtId && f.data[0] == co::kNmtStart && f.data[1] == node) {
        started_ |= 1U << i;
        Heartbeat(bus, i);
      }
    }
    return started_ == 0xFU;
  }
  // Step k (1-based): heartbeats and drive status now and then, the sensor frames, one grant.
  void Step(Bus& bus, int k, const Scenario& s) {
    bus.BeginStep(k);
    for (std::size_t i = 0; i < kCorners; ++i) {
      if (k % 10 == 0) Heartbeat(bus, i);
      if (k % 50 == 0) Send(bus, i, pf::CanIn::kDriverFaults, {{pf::CanIn::kDriverFaults, 0.0}});
      if (static_cast<int>(i) == s.silent_corner && k >= s.silent_from) continue;
      const double v = Velocity(i, k);
      Send(bus, i, pf::CanIn::kVelocity,
           {{pf::CanIn::kVelocity, v},
            {pf::CanIn::kDisplacement, 0.5 * std::cos(2.0 * M_PI * k / 250.0)},
            {pf::CanIn::kSensorSeq, static_cast<double>(k & 0xFFFF)}});
      Send(bus, i, pf::CanIn::kDemand, {{pf::CanIn::kDemand, Demand(i, k)}});
    }
    Send(bus, 0, pf::CanIn::kGrant, {{pf::CanIn::kGrant, static_cast<double>(k) * 1000.0}});
    bus.EndStep();
  }
  // Corner i's command if f is one.
  bool CommandOf(const can_frame& f, std::size_t* corner, Command* c) const {
    for (std::size_t i = 0; i < kCorners; ++i) {
      const pf::CanProfile& p = *profiles_[i];
      const pf::SignalRef cmd = p.outputs[static_cast<std::size_t>(pf::CanOut::kCommand)];
      const pf::SignalRef en = p.outputs[static_cast<std::size_t>(pf::CanOut::kEnable)];
      if (codecs_[i]->Find(f) != cmd.message) continue;
      *corner = i;
      (void)codecs_[i]->Get(f, cmd, &c->current_ma);
      (void)codecs_[i]->Get(f, en, &c->enable);
      return true;
    }
    return false;
  }

 private:
  void Heartbeat(Bus& bus, std::size_t i) {
    can_frame h{};
    h.can_id = co::HeartbeatId(profiles_[i]->canopen->node_id);
    h.len = 1;
    h.data[0] = co::kStateOperational;
    bus.Send(h);
  }
  // The message carrying role `of` in corner i's profile, with the roles' values.
  void Send(Bus& bus, std::size_t i, pf::CanIn of,
            std::initializer_list<std::pair<pf::CanIn, double>> values) {
    const pf::CanProfile& p = *profiles_[i];
    const int m = p.inputs[static_cast<std::size_t>(of)].message;
    can_frame f{};
    codecs_[i]->Begin(m, &f);
    for (const auto& [role, v] : values) {
      EXPECT_EQ(codecs_[i]->Set(&f, p.inputs[static_cast<std::size_t>(role)], v),
                protocol::SignalError::kNone);
    }
    codecs_[i]->Seal(m, &f);
    bus.Send(f);
  }

  std::array<std::shared_ptr<const pf::CanProfile>, kCorners> profiles_;
  std::array<std::unique_ptr<pf::FrameCodec>, kCorners> codecs_;
  std::uint32_t started_ = 0;
};

// Until every drive is started (at most rounds polls of 5 ms, or failed()): true when they are.
template <typename Failed>
bool StartDrives(Bus& bus, Vehicle& vehicle, int rounds, Failed failed) {
  std::vector<can_frame> got;
  bool all_started = false;
  for (int round = 0; round < rounds && !all_started && !failed(); ++round) {
    got.clear();
    bus.Poll(5, &got);
    for (const can_frame& f : got) all_started = vehicle.StartUp(bus, f) || all_started;
  }
  return all_started;
}

// The four commands of step k awaited (at most about 10 s). "" or why not; *heartbeats: the
// firmware's CANopen heartbeats (0x701) heard meanwhile.
inline std::string AwaitCommands(Bus& bus, const Vehicle& vehicle, int k, Step* step,
                                 std::uint64_t* heartbeats) {
  std::vector<can_frame> got;
  std::uint32_t have = 0;
  for (int round = 0; round < 5000 && have != 0xFU; ++round) {
    got.clear();
    bus.Poll(2, &got);
    for (const can_frame& f : got) {
      if ((f.can_id & CAN_SFF_MASK) == co::HeartbeatId(1)) ++*heartbeats;
      std::size_t i = 0;
      Command c;
      if (!vehicle.CommandOf(f, &i, &c)) continue;
      if ((have & (1U << i)) != 0) {
        return "step " + std::to_string(k) + ": two commands of corner " + std::to_string(i);
      }
      have |= 1U << i;
      (*step)[i] = c;
    }
  }
  if (have != 0xFU) {
    return "step " + std::to_string(k) + ": commands of corners " + std::to_string(have);
  }
  return "";
}

// Step k sent, then its commands awaited (AwaitCommands).
inline std::string PlayStep(Bus& bus, Vehicle& vehicle, int k, const Scenario& s, Step* step,
                            std::uint64_t* heartbeats) {
  vehicle.Step(bus, k, s);
  return AwaitCommands(bus, vehicle, k, step, heartbeats);
}

}  // namespace mrd::test::corners
