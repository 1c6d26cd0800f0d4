// Time never runs backwards in lockstep, whatever arrives: a time grant older than the current
// one (a reordered or replayed grant frame, a grant register written back) leaves the device's
// granted time and its samples' stamps where they were, on CAN (the built-in mrd-native
// profile), over Modbus TCP (the built-in register map and the modbus-float32 device profile),
// and an encoder edge reported late after a caught-up read does not move the GPIO sample's
// stamp back either; nor does a passed deadline move the dry run's lockstep clock, nor an
// older grant the loop's grant clock.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <thread>

#include "can_device_peer.hpp"
#include "gpio_test_peer.hpp"
#include "modbus_lockstep_setup.hpp"
#include "modbus_test_peers.hpp"
#include "mrd/firmware/io.hpp"
#include "mrd/firmware/io/gpio/gpio_device.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

namespace pc = protocol::can;

constexpr std::int64_t kMs = 1'000'000;  // [ns]

// ---- The dry run's lockstep clock ----

// A deadline already passed (a period that overran) leaves simulated time where it is.
TEST(LockstepClockOrder, ADeadlineInThePastLeavesTheClockWhereItIs) {
  LockstepClock clock(5 * kMs);
  clock.SleepUntil(3 * kMs);
  EXPECT_EQ(clock.Now(), 5 * kMs);
  clock.SleepUntil(7 * kMs);
  EXPECT_EQ(clock.Now(), 7 * kMs);
}

// ---- The loop's grant clock ----

// Hands out queued grants; an empty queue is a harness that says nothing for the slice.
class QueuedGrants final : public TimeGrantSource {
 public:
  bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) override {
    if (grants.empty()) {
      std::this_thread::sleep_for(std::chrono::nanoseconds(timeout_ns));
      return false;
    }
    *t_ns = grants.front();
    grants.pop_front();
    return true;
  }
  std::deque<std::int64_t> grants;
};

// An older grant is the last word before the harness goes: the clock halts at the newest
// time it was granted, not at the older one.
TEST(GrantClockOrder, AnOlderGrantBeforeTheHarnessGoesLeavesTheTimeWhereItWas) {
  QueuedGrants src;
  GrantClock clock(src, 30 * kMs);
  src.grants = {3 * kMs};
  clock.SleepUntil(3 * kMs);
  ASSERT_EQ(clock.Now(), 3 * kMs);
  src.grants = {1 * kMs};
  clock.SleepUntil(4 * kMs);
  EXPECT_TRUE(clock.gave_up());
  EXPECT_EQ(clock.Now(), 3 * kMs);
  EXPECT_EQ(clock.grants(), 2u);
}

// ---- CAN ----

class CanGrantOrder : public CanDevicePeerTest {
 protected:
  void SetUp() override {
    CanConfig c = AllRouted();
    c.lockstep = true;
    Make(c);
  }
  // One harness step: the motion frame (velocity v), then the grant [ms], both with `counter`.
  void Step(double v, std::uint16_t seq, std::uint64_t grant_ms, std::uint8_t counter) {
    SendMotion(v, 0.0, seq, counter);
    SendGrant(grant_ms, counter);
  }
  void SendGrant(std::uint64_t grant_ms, std::uint8_t counter) {
    can_frame f{};
    ASSERT_EQ(pc::Encode(pc::TimeGrant{grant_ms * 1000U, counter}, &f), pc::Reject::kNone);
    PeerSend(f);
  }
  // The granted time WaitGrant hands the clock [ns]; -1 when no grant came within 2 s.
  std::int64_t Wait() {
    std::int64_t t = -1;
    return device_->WaitGrant(2'000 * kMs, &t) ? t : -1;
  }
};

TEST_F(CanGrantOrder, AGrantOlderThanTheCurrentOneMovesNeitherTimeNorStamps) {
  Step(1.0, 1, 5, 0);
  ASSERT_EQ(Wait(), 5 * kMs);
  SensorFrame f;
  ASSERT_EQ(Read(&f), IoStatus::kOk);
  EXPECT_EQ(f[Input::kVelocity].value, 1.0);
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, 5 * kMs);

  // A valid frame (its counter moves on) granting 3 ms after 5 ms: time stays at 5 ms, and the
  // values that came with it are stamped 5 ms, not 3 ms.
  Step(2.0, 2, 3, 1);
  EXPECT_EQ(Wait(), 5 * kMs);
  f = SensorFrame{};
  ASSERT_EQ(Read(&f), IoStatus::kOk);
  EXPECT_EQ(f[Input::kVelocity].value, 2.0);
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, 5 * kMs);
  EXPECT_EQ(f[Input::kDisplacement].stamp_ns, 5 * kMs);

  // The next grant moves time on as usual.
  Step(3.0, 3, 6, 2);
  EXPECT_EQ(Wait(), 6 * kMs);
  f = SensorFrame{};
  ASSERT_EQ(Read(&f), IoStatus::kOk);
  EXPECT_EQ(f[Input::kVelocity].value, 3.0);
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, 6 * kMs);
}

// The same grant frame twice (same rolling counter): the copy is refused as a repeat and
// counted; it is no grant at all (nothing to wait for) and changes no stamp.
TEST_F(CanGrantOrder, ARepeatedGrantFrameIsRefusedAndChangesNothing) {
  Step(1.0, 1, 5, 0);
  ASSERT_EQ(Wait(), 5 * kMs);
  SensorFrame f;
  ASSERT_EQ(Read(&f), IoStatus::kOk);
  SendGrant(5, 0);
  std::int64_t t = -1;
  EXPECT_FALSE(device_->WaitGrant(50 * kMs, &t));
  EXPECT_EQ(Errors(IoError::kRejectedFrame), 1U);
  Step(2.0, 2, 6, 1);
  EXPECT_EQ(Wait(), 6 * kMs);
  f = SensorFrame{};
  ASSERT_EQ(Read(&f), IoStatus::kOk);
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, 6 * kMs);
}

// ---- Modbus TCP (lockstep: the grant registers follow the step's sensor block) ----

hil::SensorOutput Sample(std::uint32_t seq, double v) {
  hil::SensorOutput o;
  o.seq = seq;
  o.sample.v = v;
  o.sample.x = 0.5;
  o.sample.demand = 100.0;
  return o;
}

// One lockstep period as the loop runs it: wait for the grant, read, command, publish status.
struct ModbusLoopSide {
  explicit ModbusLoopSide(ModbusDevice& d) : device(d) {}
  // The grant [ns] WaitGrant hands the clock within timeout_ms; -1: none.
  std::int64_t Wait(int timeout_ms) {
    std::int64_t t = -1;
    return device.WaitGrant(timeout_ms * kMs, &t) ? t : -1;
  }
  // Reads until the sample with velocity v [cm/s] has arrived (true), within 3 s.
  bool ReadValue(double v, SensorFrame* f) {
    return test::WaitFor([&] {
      *f = SensorFrame{};
      IoError why = IoError::kNone;
      (void)device.Read(::mrd::test::NowIo(), f, &why);
      return std::fabs((*f)[Input::kVelocity].value - v) < 1e-4;
    });
  }
  void Answer() {
    IoError why = IoError::kNone;
    ++tick;
    (void)device.Write(::mrd::test::NowIo(), {0.5, true, false, tick}, &why);
    device.PublishStatus(::mrd::test::NowIo(), TelemetrySnapshot{});
  }
  ModbusDevice& device;
  std::uint64_t tick = 0;
};

// The harness (port) grants 5 ms, then writes a grant of 3 ms with the next step's block, then
// 6 ms: the device's time and stamps go 5, 5, 6 ms.
void OlderGrantChangesNothing(hil::PlantPort& port, ModbusDevice& device) {
  std::string error;
  port.SetLockstep(true);
  ASSERT_TRUE(device.Configure(&error)) << error;
  ASSERT_TRUE(device.Activate(&error)) << error;
  ModbusLoopSide loop(device);
  SensorFrame f;

  port.Publish(Sample(1, 1.0));
  ASSERT_TRUE(port.SendGrant(5 * kMs));
  ASSERT_EQ(loop.Wait(3000), 5 * kMs);
  ASSERT_TRUE(loop.ReadValue(1.0, &f));
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, 5 * kMs);
  loop.Answer();

  port.Publish(Sample(2, 2.0));
  ASSERT_TRUE(port.SendGrant(3 * kMs));
  ASSERT_TRUE(loop.ReadValue(2.0, &f));
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, 5 * kMs);  // not 3 ms
  EXPECT_EQ(loop.Wait(100), -1);                     // and no grant to wait for
  loop.Answer();

  port.Publish(Sample(3, 3.0));
  ASSERT_TRUE(port.SendGrant(6 * kMs));
  ASSERT_EQ(loop.Wait(3000), 6 * kMs);
  ASSERT_TRUE(loop.ReadValue(3.0, &f));
  EXPECT_EQ(f[Input::kVelocity].stamp_ns, 6 * kMs);
  device.Deactivate();
}

TEST(ModbusGrantOrder, AGrantOlderThanTheCurrentOneMovesNeitherTimeNorStamps) {
  const int p = test::FreeTcpPort();
  auto port = hil::MakeModbusTcpPort("127.0.0.1:" + std::to_string(p));
  std::string error;
  ASSERT_TRUE(port->Open(&error)) << error;
  ModbusDevice device(LockstepTcp(p, 200 * kMs));  // a loaded machine is no fault here
  OlderGrantChangesNothing(*port, device);
  port->Close();
}

TEST(ModbusGrantOrder, OnADeviceProfileAnOlderGrantMovesNeitherTimeNorStamps) {
  const auto mp = Float32Profile();
  std::string error;
  const int p = test::FreeTcpPort();
  auto port = hil::MakeModbusProfilePort(false, "127.0.0.1:" + std::to_string(p), mp);
  ASSERT_TRUE(port->Open(&error)) << error;
  ModbusConfig c = LockstepTcp(p, 200 * kMs);
  c.modbus_profile = mp;
  ModbusDevice device(c);
  OlderGrantChangesNothing(*port, device);
  port->Close();
}

// ---- GPIO encoder ----

// Caught up at rest, the sample is stamped at the read (minus the horizon); edges the chip
// then reports 100 ms late (more than one read takes) carry their own older stamps: the
// sample's stamp stays where it was until the device has caught up again.
TEST(GpioStampOrder, EdgesReportedLateDoNotMoveTheSampleStampBack) {
  test::GpioPeer peer("late-edges");
  ASSERT_TRUE(peer.ok()) << peer.error();
  GpioConfig c;
  c.enabled = true;
  c.inputs = Bit(Input::kDisplacement);
  c.sim_chip = peer.path();
  c.encoder_a_line = peer.lines.a;
  c.encoder_b_line = peer.lines.b;
  GpioDevice device(c);
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  SensorFrame f;
  IoError why = IoError::kNone;
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(device.Read(::mrd::test::NowIo(), &f, &why), IoStatus::kOk);
  const std::int64_t at_rest = f[Input::kDisplacement].stamp_ns;
  ASSERT_GT(at_rest, 0);

  peer.MoveTo(300, 100 * kMs);  // a backlog of edges stamped 100 ms ago
  std::int64_t previous = at_rest;
  for (int k = 0; k < 8; ++k) {
    f = SensorFrame{};
    (void)device.Read(::mrd::test::NowIo(), &f, &why);
    EXPECT_GE(f[Input::kDisplacement].stamp_ns, previous) << "read " << k;
    previous = f[Input::kDisplacement].stamp_ns;
  }
  EXPECT_EQ(device.encoder_count(), 300);
  device.Deactivate();
}

}  // namespace
}  // namespace mrd::firmware
