// The CAN device's fault_reset bit against a peer on a socketpair playing a driver that latches
// its fault (DriverStatus.DriverFaults): an edge (1 in one command frame, 0 in the next) only
// while the driver reports the fault and the firmware has no other cause, at most once per
// [can] fault_reset_ms of device time, none once the driver is clean and none in the shutdown
// frame; the same periods allocate nothing. This executable replaces the allocator
// (alloc_counter.hpp). Time is handed in (1 ms periods), no sleeping, no wall clock.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "support/alloc_counter.hpp"

namespace mrd::firmware {
namespace {

namespace pf = profile;
constexpr std::int64_t kPeriod = 1'000'000;  // [ns]

// docs/mrd.dbc with a FaultReset bit in DriverCommand (bit 19, free in the native layout).
std::shared_ptr<const pf::CanProfile> FaultResetProfile() {
  std::ifstream in(std::string(MRD_SOURCE_DIR) + "/docs/mrd.dbc");
  std::string dbc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string after = " SG_ SafeState : 18|1@1+ (1,0) [0|1] \"\" Driver\n";
  const std::size_t at = dbc.find(after);
  if (at == std::string::npos) return nullptr;
  dbc.insert(at + after.size(), " SG_ FaultReset : 19|1@1+ (1,0) [0|1] \"\" Driver\n");
  const std::string text = R"(name = "latching-driver"
dbc = "mrd.dbc"
[inputs]
driver_faults = "DriverStatus.DriverFaults"
[outputs]
command = "DriverCommand.VoltageSetpoint"
safe = "DriverCommand.SafeState"
fault_reset = "DriverCommand.FaultReset"
)";
  auto p = std::make_shared<pf::CanProfile>();
  std::string error;
  if (!pf::ParseCanProfile(text, "latching.toml", &dbc, p.get(), &error)) {
    ADD_FAILURE() << error;
    return nullptr;
  }
  return p;
}

constexpr unsigned Cause(FaultCause c) { return 1U << static_cast<unsigned>(c); }

// The scenario's periods k = 0 .. kPeriods-1 (device time k ms after activation):
//   [0, 300)     driver fault latched, and the firmware has a stale sensor too: no edge;
//   [300, 2500)  driver fault latched, nothing else: edges at 301, 1301, 2301 ms;
//   [2500, 3300) the driver is clean (it cleared on a reset): no edge;
//   3300         the driver latches again, an edge is due (1000 ms since the last) but the
//                firmware shuts down instead: the shutdown frame carries 0.
constexpr int kPeriods = 3300;

struct Observed {
  std::array<int, 8> ones_at{};  // the periods whose command frame carried 1 (the first 8)
  int ones = 0;                  // command frames carrying 1
  int commands = 0;              // command frames
  int shutdown_bit = -1;         // fault_reset in the shutdown frame (-1: none seen)
  bool back_to_back = false;     // two consecutive frames carrying 1 (no edge between)
};

class CanFaultResetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    profile_ = FaultResetProfile();
    ASSERT_NE(profile_, nullptr);
    codec_ = std::make_unique<pf::FrameCodec>(*profile_);
    command_msg_ = profile_->outputs[static_cast<std::size_t>(pf::CanOut::kCommand)].message;
    status_msg_ = profile_->inputs[static_cast<std::size_t>(pf::CanIn::kDriverFaults)].message;
    int sv[2];
    ASSERT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
    peer_ = sv[1];
    CanConfig c;
    c.enabled = true;
    c.outputs = Bit(Output::kCommand);
    c.can_profile = profile_;
    c.fault_reset_ns = 1'000'000'000;  // the default, 1000 ms
    device_ = std::make_unique<CanDevice>(c, sv[0]);
    std::string error;
    ASSERT_TRUE(device_->Configure(&error)) << error;
    ASSERT_TRUE(device_->Activate(&error)) << error;
    t0_ = common::MonotonicNs();
  }
  void TearDown() override {
    device_.reset();
    close(peer_);
  }

  void SendFaults(unsigned faults) {
    can_frame f{};
    codec_->Begin(status_msg_, &f);
    (void)codec_->Set(&f, profile_->inputs[static_cast<std::size_t>(pf::CanIn::kDriverFaults)],
                      static_cast<double>(faults));
    codec_->Seal(status_msg_, &f);
    ASSERT_EQ(write(peer_, &f, sizeof f), static_cast<ssize_t>(sizeof f));
  }
  // The fault_reset bits of the command frames the device sent since the last call.
  void Drain(int k, bool shutdown) {
    can_frame f{};
    while (recv(peer_, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) {
      if (codec_->Find(f) != command_msg_) continue;
      double bit = -1.0;
      (void)codec_->Get(f, profile_->outputs[static_cast<std::size_t>(pf::CanOut::kFaultReset)],
                        &bit);
      if (shutdown) {
        seen_.shutdown_bit = static_cast<int>(bit);
        continue;
      }
      ++seen_.commands;
      if (bit == 1.0) {
        if (last_one_ == k - 1) seen_.back_to_back = true;
        if (seen_.ones < static_cast<int>(seen_.ones_at.size())) {
          seen_.ones_at[static_cast<std::size_t>(seen_.ones)] = k;
        }
        ++seen_.ones;
        last_one_ = k;
      }
    }
  }
  // The loop's order per period: Read, Write, PublishStatus (the causes the next Write sees).
  void Run() {
    for (int k = 0; k < kPeriods; ++k) {
      const IoTime io{t0_ + k * kPeriod, t0_ + k * kPeriod};
      if (k == 0) SendFaults(0x04);     // latched
      if (k == 2500) SendFaults(0x00);  // cleared by the reset
      SensorFrame frame;
      IoError why = IoError::kNone;
      (void)device_->Read(io, &frame, &why);
      TelemetrySnapshot stats;
      stats.safe = true;
      stats.active_causes = frame.fault_line ? Cause(FaultCause::kFaultLine) : 0U;
      if (k < 300) stats.active_causes |= Cause(FaultCause::kStaleSensor);
      (void)device_->Write(io, {0.0, false, true, static_cast<std::uint64_t>(k)}, &why);
      device_->PublishStatus(io, stats);
      Drain(k, false);
    }
    SendFaults(0x04);  // latched again; an edge would be due now
    SensorFrame frame;
    IoError why = IoError::kNone;
    const IoTime io{t0_ + kPeriods * kPeriod, t0_ + kPeriods * kPeriod};
    (void)device_->Read(io, &frame, &why);
    device_->Deactivate();
    Drain(kPeriods, true);
  }

  std::shared_ptr<const pf::CanProfile> profile_;
  std::unique_ptr<pf::FrameCodec> codec_;
  int command_msg_ = -1, status_msg_ = -1;
  int peer_ = -1;
  std::unique_ptr<CanDevice> device_;
  std::int64_t t0_ = 0;
  Observed seen_;
  int last_one_ = -10;
};

TEST_F(CanFaultResetTest, ALatchedDriverFaultGetsOneEdgePerIntervalAndNoneAtShutdown) {
  Run();
  EXPECT_EQ(seen_.commands, kPeriods);
  ASSERT_EQ(seen_.ones, 3);
  // Not while another cause (stale) was active; a Write sees the previous period's status, so
  // the first edge is in period 301 (the status of 300 is the first clean one).
  EXPECT_EQ(seen_.ones_at[0], 301);
  EXPECT_EQ(seen_.ones_at[1], 1301);  // one per fault_reset_ms
  EXPECT_EQ(seen_.ones_at[2], 2301);
  EXPECT_FALSE(seen_.back_to_back);  // 1 in one frame, then 0: a rising edge each
  EXPECT_EQ(seen_.shutdown_bit, 0);  // the shutdown frame went out, without the reset
}

TEST_F(CanFaultResetTest, TheFaultResetPeriodsAllocateNothing) {
  test::AllocationGuard guard;
  Run();
  const std::uint64_t allocations = guard.count();
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(seen_.ones, 3);  // the path really ran
}

}  // namespace
}  // namespace mrd::firmware
