// The GPIO device on the simulated chip: enable follows the commanded state (low when safe and
// after Deactivate), the heartbeat toggles per write, the fault line with both polarities, the
// quadrature encoder in both directions with illegal transitions rejected, displacement
// scaling and stamps, lost edges, start-up errors.
#include "mrd/firmware/io/gpio/gpio_device.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "gpio_test_peer.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/devices.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

using test::GpioPeer;

GpioConfig ConfigFor(const GpioPeer& peer) {
  GpioConfig c;
  c.enabled = true;
  c.inputs = Bit(Input::kDisplacement) | Bit(Input::kFaultLine);
  c.outputs = Bit(Output::kEnable) | Bit(Output::kHeartbeat);
  c.sim_chip = peer.path();
  c.encoder_a_line = peer.lines.a;
  c.encoder_b_line = peer.lines.b;
  c.fault_line = peer.lines.fault;
  c.enable_line = peer.lines.enable;
  c.heartbeat_line = peer.lines.heartbeat;
  return c;
}

struct Started {
  std::unique_ptr<GpioDevice> device;
  std::string error;
};

Started Start(const GpioConfig& c) {
  Started s{std::make_unique<GpioDevice>(c), {}};
  if (!s.device->Configure(&s.error) || !s.device->Activate(&s.error)) s.device.reset();
  return s;
}

IoStatus ReadOnce(GpioDevice& d, SensorFrame* frame, IoError* why) {
  *frame = SensorFrame{};
  *why = IoError::kNone;
  return d.Read(::mrd::test::NowIo(), frame, why);
}

TEST(GpioDevice, EnableIsHighOnlyWhenTheLoopCommandsTheDriverEnabled) {
  GpioPeer peer("enable");
  ASSERT_TRUE(peer.ok()) << peer.error();
  peer.chip().SetValue(peer.lines.enable, true, 1);  // left high by someone before us
  Started s = Start(ConfigFor(peer));
  ASSERT_NE(s.device, nullptr) << s.error;
  EXPECT_FALSE(peer.enable());  // requested low
  IoError why = IoError::kNone;
  EXPECT_EQ(s.device->Write(::mrd::test::NowIo(), {1.0, true, false, 0}, &why), IoStatus::kOk);
  EXPECT_TRUE(peer.enable());
  EXPECT_TRUE(s.device->enable_level());
  EXPECT_EQ(s.device->Write(::mrd::test::NowIo(), {0.0, false, true, 1}, &why),
            IoStatus::kOk);  // safe state
  EXPECT_FALSE(peer.enable());
  EXPECT_EQ(s.device->Write(::mrd::test::NowIo(), {0.5, true, true, 2}, &why),
            IoStatus::kOk);  // safe wins
  EXPECT_FALSE(peer.enable());
  EXPECT_EQ(s.device->Write(::mrd::test::NowIo(), {0.5, true, false, 3}, &why), IoStatus::kOk);
  EXPECT_TRUE(peer.enable());
  s.device->Deactivate();
  EXPECT_FALSE(peer.enable());
  EXPECT_EQ(s.device->Write(::mrd::test::NowIo(), {0.5, true, false, 4}, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kDisconnected);
  EXPECT_GE(s.device->counters().tx_ok, 8U);
  EXPECT_EQ(s.device->counters().tx_failed, 1U);
}

TEST(GpioDevice, HeartbeatTogglesOncePerWriteInEveryState) {
  GpioPeer peer("heartbeat");
  ASSERT_TRUE(peer.ok()) << peer.error();
  Started s = Start(ConfigFor(peer));
  ASSERT_NE(s.device, nullptr) << s.error;
  const std::uint64_t before = peer.heartbeat_edges();
  bool level = peer.heartbeat();
  IoError why = IoError::kNone;
  for (int k = 0; k < 20; ++k) {
    const bool safe = k % 3 == 0;
    ASSERT_EQ(s.device->Write(::mrd::test::NowIo(),
                              {safe ? 0.0 : 1.0, !safe, safe, static_cast<std::uint64_t>(k)}, &why),
              IoStatus::kOk);
    EXPECT_NE(peer.heartbeat(), level) << "write " << k;
    level = peer.heartbeat();
  }
  EXPECT_EQ(peer.heartbeat_edges() - before, 20U);
}

TEST(GpioDevice, FaultLineActiveHighAndActiveLow) {
  for (const bool active_low : {false, true}) {
    GpioPeer peer(active_low ? "fault-low" : "fault-high");
    ASSERT_TRUE(peer.ok()) << peer.error();
    GpioConfig c = ConfigFor(peer);
    c.fault_active_low = active_low;
    Started s = Start(c);
    ASSERT_NE(s.device, nullptr) << s.error;
    SensorFrame f;
    IoError why = IoError::kNone;
    for (const bool level : {false, true, false, true}) {
      peer.SetFault(level);
      EXPECT_NE(ReadOnce(*s.device, &f, &why), IoStatus::kFault);
      EXPECT_EQ(f.fault_line, level != active_low) << "active_low " << active_low;
      EXPECT_EQ(s.device->fault_asserted(), level != active_low);
    }
  }
}

TEST(GpioDevice, EncoderCountsBothDirectionsAndScalesToCentimetres) {
  GpioPeer peer("encoder");
  ASSERT_TRUE(peer.ok()) << peer.error();
  peer.MoveTo(7);  // where the encoder is at start-up: the device's zero
  GpioConfig c = ConfigFor(peer);
  c.counts_per_cm = 250.0;
  Started s = Start(c);
  ASSERT_NE(s.device, nullptr) << s.error;
  SensorFrame f;
  IoError why = IoError::kNone;
  peer.MoveTo(7 + 500);
  EXPECT_EQ(ReadOnce(*s.device, &f, &why), IoStatus::kOk) << IoErrorName(why);
  // 64 edges per line and period: 500 edges take a few periods.
  for (int k = 0; k < 10; ++k) ReadOnce(*s.device, &f, &why);
  EXPECT_EQ(s.device->encoder_count(), 500);
  EXPECT_DOUBLE_EQ(f[Input::kDisplacement].value, 2.0);
  for (const std::int64_t target : {407, 307, 207, 107, 7, -93, -123}) {
    peer.MoveTo(target);  // in chunks that fit the chip's event rings
    for (int k = 0; k < 4; ++k) ReadOnce(*s.device, &f, &why);
  }
  EXPECT_EQ(s.device->encoder_count(), -130);
  EXPECT_DOUBLE_EQ(f[Input::kDisplacement].value, -130.0 / 250.0);
  const DeviceCounters n = s.device->counters();
  EXPECT_EQ(n.rx_ok, 500U + 630U);
  EXPECT_EQ(n.rx_rejected, 0U);
}

TEST(GpioDevice, IllegalTransitionIsRejectedAndCountingGoesOn) {
  GpioPeer peer("glitch");
  ASSERT_TRUE(peer.ok()) << peer.error();
  Started s = Start(ConfigFor(peer));
  ASSERT_NE(s.device, nullptr) << s.error;
  SensorFrame f;
  IoError why = IoError::kNone;
  peer.MoveTo(10);
  ReadOnce(*s.device, &f, &why);
  ASSERT_EQ(s.device->encoder_count(), 10);
  peer.Glitch();  // both lines in one event
  ReadOnce(*s.device, &f, &why);
  EXPECT_EQ(s.device->encoder_count(), 10);  // held
  DeviceCounters n = s.device->counters();
  EXPECT_EQ(n.rx_rejected, 1U);
  EXPECT_EQ(n.errors[static_cast<std::size_t>(IoError::kRejectedFrame)], 1U);
  EXPECT_EQ(n.last_error, IoError::kRejectedFrame);
  // From the new levels on, edges count again (the peer is now at 12 by its own books).
  peer.MoveTo(12 - 5);
  ReadOnce(*s.device, &f, &why);
  EXPECT_EQ(s.device->encoder_count(), 10 - 5);
  n = s.device->counters();
  EXPECT_EQ(n.rx_ok, 15U);
  EXPECT_EQ(n.rx_rejected, 1U);
}

TEST(GpioDevice, EdgesYoungerThanTheHorizonWaitAPeriod) {
  GpioPeer peer("horizon");
  ASSERT_TRUE(peer.ok()) << peer.error();
  Started s = Start(ConfigFor(peer));
  ASSERT_NE(s.device, nullptr) << s.error;
  SensorFrame f;
  IoError why = IoError::kNone;
  peer.MoveTo(3, /*age_ns=*/-50'000'000);  // stamped 50 ms ahead: not applied yet
  ReadOnce(*s.device, &f, &why);
  EXPECT_EQ(s.device->encoder_count(), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(60));
  ReadOnce(*s.device, &f, &why);
  EXPECT_EQ(s.device->encoder_count(), 3);
}

TEST(GpioDevice, AtRestTheSampleIsFresh) {
  GpioPeer peer("rest");
  ASSERT_TRUE(peer.ok()) << peer.error();
  Started s = Start(ConfigFor(peer));
  ASSERT_NE(s.device, nullptr) << s.error;
  SensorFrame f;
  IoError why = IoError::kNone;
  // No motion: the count is current as of the read (minus the horizon), not stale.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(ReadOnce(*s.device, &f, &why), IoStatus::kOk);
  const std::int64_t now = common::MonotonicNs();
  EXPECT_LE(now - f[Input::kDisplacement].stamp_ns, 5'000'000);
  EXPECT_GE(now - f[Input::kDisplacement].stamp_ns, GpioDevice::kEdgeHorizonNs);
  EXPECT_DOUBLE_EQ(f[Input::kDisplacement].value, 0.0);
}

TEST(GpioDevice, WithABacklogTheSampleCarriesTheLatestEdgeStamp) {
  GpioPeer peer("backlog");
  ASSERT_TRUE(peer.ok()) << peer.error();
  Started s = Start(ConfigFor(peer));
  ASSERT_NE(s.device, nullptr) << s.error;
  SensorFrame f;
  IoError why = IoError::kNone;
  // More edges than one period reads, stamped 100 ms ago.
  peer.MoveTo(300, 100'000'000);
  ReadOnce(*s.device, &f, &why);
  // 64 edges of each line read; the last B edge waits for the A edges still queued.
  EXPECT_EQ(s.device->encoder_count(),
            2 * static_cast<std::int64_t>(GpioDevice::kMaxEdgesPerRead) - 1);
  EXPECT_EQ(f[Input::kDisplacement].stamp_ns, s.device->last_edge_ns());
  EXPECT_GT(common::MonotonicNs() - f[Input::kDisplacement].stamp_ns, 90'000'000);
  for (int k = 0; k < 4; ++k) ReadOnce(*s.device, &f, &why);
  EXPECT_EQ(s.device->encoder_count(), 300);
  EXPECT_LE(common::MonotonicNs() - f[Input::kDisplacement].stamp_ns, 5'000'000);  // caught up
}

TEST(GpioDevice, LostEdgesAreAFault) {
  GpioPeer peer("lost");
  ASSERT_TRUE(peer.ok()) << peer.error();
  Started s = Start(ConfigFor(peer));
  ASSERT_NE(s.device, nullptr) << s.error;
  SensorFrame f;
  IoError why = IoError::kNone;
  peer.MoveTo(4 * static_cast<std::int64_t>(sim_gpio::kRingSize));  // laps each line's ring
  EXPECT_EQ(ReadOnce(*s.device, &f, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kOverflow);
  const DeviceCounters n = s.device->counters();
  EXPECT_GT(n.errors[static_cast<std::size_t>(IoError::kOverflow)], 0U);
  EXPECT_GT(n.rx_rejected, 0U);
}

TEST(GpioDevice, StartUpErrorsSayWhy) {
  GpioConfig c;
  c.enabled = true;
  c.sim_chip = "/tmp/mrd-gpio-missing-" + std::to_string(getpid()) + ".chip";
  c.outputs = Bit(Output::kEnable);
  c.enable_line = 1;
  GpioDevice missing(c);
  std::string error;
  EXPECT_FALSE(missing.Configure(&error));
  EXPECT_NE(error.find(c.sim_chip), std::string::npos) << error;
  EXPECT_NE(error.find("mrd-hil serve --port gpio="), std::string::npos) << error;

  GpioPeer peer("badline");
  ASSERT_TRUE(peer.ok()) << peer.error();
  c.sim_chip = peer.path();
  c.enable_line = 64;
  GpioDevice bad_line(c);
  EXPECT_FALSE(bad_line.Configure(&error));
  EXPECT_NE(error.find("no line 64"), std::string::npos) << error;

  GpioConfig real;
  real.enabled = true;
  real.chip = "/dev/gpiochip-none";
  GpioDevice board(real);
  EXPECT_FALSE(board.Configure(&error));
  EXPECT_NE(error.find("gpio: cannot open chip '/dev/gpiochip-none'"), std::string::npos) << error;

  IoError why = IoError::kNone;
  SensorFrame f;
  EXPECT_EQ(board.Read(::mrd::test::NowIo(), &f, &why), IoStatus::kFault);
  EXPECT_EQ(why, IoError::kDisconnected);
}

// The device's work per period on the simulated chip (Read with ~5 edges + Write), measured
// and printed; the bound is loose (a loaded VM), the point is the figure.
TEST(GpioDevice, WorkPerPeriodIsMicroseconds) {
  GpioPeer peer("cost");
  ASSERT_TRUE(peer.ok()) << peer.error();
  Started s = Start(ConfigFor(peer));
  ASSERT_NE(s.device, nullptr) << s.error;
  SensorFrame f;
  IoError why = IoError::kNone;
  std::vector<double> us;
  for (int k = 0; k < 5000; ++k) {
    peer.MoveTo(peer.count() + (k % 400 < 200 ? 5 : -5));
    const std::int64_t t0 = common::MonotonicNs();
    ReadOnce(*s.device, &f, &why);
    s.device->Write(::mrd::test::NowIo(), {1.0, true, false, static_cast<std::uint64_t>(k)}, &why);
    us.push_back(static_cast<double>(common::MonotonicNs() - t0) * 1e-3);
  }
  std::sort(us.begin(), us.end());
  const double median = us[us.size() / 2], p99 = us[us.size() * 99 / 100], max = us.back();
  std::printf(
      "gpio device Read+Write per period (5 edges): median %.2f us, p99 %.2f us, "
      "max %.2f us\n",
      median, p99, max);
  EXPECT_EQ(s.device->counters().rx_ok, 25000U);
  EXPECT_LT(median, 100.0);
}

TEST(GpioDevice, TheFactoryBuildsIt) {
  IoConfig io;
  io.gpio.enabled = true;
  io.gpio.sim_chip = "/tmp/x.chip";
  std::vector<std::unique_ptr<BusDevice>> devices;
  std::string error;
  ASSERT_TRUE(MakeDevices(io, &devices, &error)) << error;
  ASSERT_EQ(devices.size(), 1U);
  EXPECT_STREQ(devices[0]->name(), "gpio");
  EXPECT_EQ(devices[0]->fault_cause(), FaultCause::kGpioBus);
}

}  // namespace
}  // namespace mrd::firmware
