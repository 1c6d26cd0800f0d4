// The firmware's CAN device with a CANopen (CiA 301) drive (the shipped canopen-drive profile)
// against a peer the test scripts on the other end of a socketpair (labels fieldbus, profile):
// NMT start and the start-up SDO downloads byte for byte; a refusal and a silent drive fail the
// start-up with the entry, index, abort code and its meaning; in lockstep (time is the grants
// the test sends) the firmware's heartbeat every heartbeat_ms, the drive's heartbeat lost for
// longer than its timeout or not operational -> fault_line, a boot-up -> the SDO list again,
// NMT start, safe until operational; and those loop periods allocate nothing. This executable
// replaces the allocator (alloc_counter.hpp).
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/canopen_codec.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "support/alloc_counter.hpp"
#include "support/io_time.hpp"

namespace mrd::firmware {
namespace {

namespace co = profile::canopen;
const std::string kProfile = std::string(MRD_SOURCE_DIR) + "/firmware/profiles/canopen-drive.toml";

std::shared_ptr<const profile::CanProfile> LoadProfile(const std::string& path = kProfile) {
  auto p = std::make_shared<profile::CanProfile>();
  std::string error;
  EXPECT_TRUE(profile::LoadCanProfile(path, p.get(), &error)) << error;
  return p;
}

CanConfig Routed(std::shared_ptr<const profile::CanProfile> p, bool lockstep) {
  CanConfig c;
  c.enabled = true;
  c.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand);
  c.outputs = Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat);
  c.can_profile = std::move(p);
  c.lockstep = lockstep;
  return c;
}

can_frame Frame(std::uint32_t id, std::initializer_list<int> bytes) {
  can_frame f{};
  f.can_id = id;
  f.len = static_cast<std::uint8_t>(bytes.size());
  int i = 0;
  for (const int b : bytes) f.data[i++] = static_cast<std::uint8_t>(b);
  return f;
}

std::vector<int> Bytes(const can_frame& f) { return std::vector<int>(f.data, f.data + f.len); }

// The drive at start-up, on a thread while Activate waits: answers each SDO download (or
// aborts the one to refuse_index), records every frame.
class ScriptedDrive {
 public:
  // wrong: every answer confirms the download of another object (index + 1).
  ScriptedDrive(int fd, int refuse_index, std::uint32_t code, bool silent, bool wrong = false)
      : fd_(fd),
        refuse_index_(refuse_index),
        code_(code),
        silent_(silent),
        wrong_(wrong),
        thread_([this] { Run(); }) {}
  ~ScriptedDrive() { Stop(); }
  // Stops and takes what the device sent last (the NMT start after the final answer).
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    can_frame f{};
    while (recv(fd_, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) {
      heard_.push_back(f);
    }
  }
  const std::vector<can_frame>& heard() const { return heard_; }

 private:
  void Run() {
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, 5) <= 0) continue;
      can_frame f{};
      if (recv(fd_, &f, sizeof f, MSG_DONTWAIT) != static_cast<ssize_t>(sizeof f)) continue;
      heard_.push_back(f);
      if (f.can_id != co::SdoRequestId(5) || silent_) continue;
      std::uint16_t index = 0;
      std::uint8_t sub = 0;
      int size = 0;
      std::uint32_t raw = 0;
      can_frame r = Frame(co::SdoResponseId(5), {0, 0, 0, 0, 0, 0, 0, 0});
      if (!co::DecodeSdoDownloadRequest(f.data, f.len, &index, &sub, &size, &raw)) continue;
      if (index == refuse_index_) {
        co::EncodeSdoAbort(index, sub, code_, r.data);
      } else if (wrong_) {
        co::EncodeSdoDownloadAck(static_cast<std::uint16_t>(index + 1), sub, r.data);
      } else {
        co::EncodeSdoDownloadAck(index, sub, r.data);
      }
      (void)write(fd_, &r, sizeof r);
    }
  }
  int fd_;
  int refuse_index_;
  std::uint32_t code_;
  bool silent_;
  bool wrong_;
  std::atomic<bool> stop_{false};
  std::vector<can_frame> heard_;
  std::thread thread_;
};

class CanopenDeviceTest : public ::testing::Test {
 protected:
  void TearDown() override {
    device_.reset();
    if (peer_ >= 0) close(peer_);
  }
  // A device on a socketpair; Activate against the scripted drive. Returns Activate's result.
  bool Start(const CanConfig& config, std::string* error, int refuse_index = -1,
             std::uint32_t code = 0, bool silent = false, bool wrong = false) {
    int sv[2];
    EXPECT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv), 0);
    peer_ = sv[1];
    profile_ = config.can_profile;
    codec_ = std::make_unique<profile::FrameCodec>(*profile_);
    device_ = std::make_unique<CanDevice>(config, sv[0]);
    EXPECT_TRUE(device_->Configure(error)) << *error;
    ScriptedDrive drive(peer_, refuse_index, code, silent, wrong);
    const bool ok = device_->Activate(error);
    drive.Stop();
    startup_ = drive.heard();
    return ok;
  }
  void PeerSend(const can_frame& f) {
    ASSERT_EQ(write(peer_, &f, sizeof f), static_cast<ssize_t>(sizeof f));
  }
  // What the device sent into sent_ (capacity reserved: the allocation guard's loop).
  void PeerDrain() {
    sent_.clear();
    can_frame f{};
    while (recv(peer_, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) {
      if (sent_.size() < sent_.capacity()) sent_.push_back(f);
    }
  }
  // One lockstep period at t_ms: the drive's heartbeat (state; < 0: none), the sensors and the
  // grant; the device's wait, read, write and status, as Loop::Tick calls them (in lockstep the
  // period's frames leave at the end of its status). The frame's fault_line; sent_: what the
  // device sent in this period.
  bool Period(int t_ms, int drive_state) {
    if (drive_state >= 0) PeerSend(Frame(co::HeartbeatId(5), {drive_state}));
    const profile::SignalRef v =
        profile_->inputs[static_cast<std::size_t>(profile::CanIn::kVelocity)];
    can_frame f{};
    codec_->Begin(v.message, &f);
    (void)codec_->Set(&f, v, 1.0);
    codec_->Seal(v.message, &f);
    PeerSend(f);
    const profile::SignalRef g = profile_->inputs[static_cast<std::size_t>(profile::CanIn::kGrant)];
    codec_->Begin(g.message, &f);
    (void)codec_->Set(&f, g, t_ms * 1000.0);
    codec_->Seal(g.message, &f);
    PeerSend(f);
    std::int64_t t = 0;
    EXPECT_TRUE(device_->WaitGrant(1'000'000'000, &t));
    EXPECT_EQ(t, t_ms * 1'000'000LL);
    SensorFrame frame;
    IoError why = IoError::kNone;
    (void)device_->Read(::mrd::test::NowIo(), &frame, &why);
    (void)device_->Write(::mrd::test::NowIo(), DriverCommand{1.0, true, false, 0}, &why);
    device_->PublishStatus(::mrd::test::NowIo(), TelemetrySnapshot{});
    PeerDrain();
    for (const can_frame& s : sent_) {
      if (s.can_id == co::HeartbeatId(1) && own_heartbeats_.size() < own_heartbeats_.capacity()) {
        own_heartbeats_.push_back(t_ms);
      }
    }
    return frame.fault_line;
  }
  // The SDO requests and NMT frames among sent_.
  std::vector<can_frame> Management() const {
    std::vector<can_frame> r;
    for (const can_frame& f : sent_) {
      if (f.can_id == co::SdoRequestId(5) || f.can_id == co::kNmtId) r.push_back(f);
    }
    return r;
  }

  std::shared_ptr<const profile::CanProfile> profile_;
  std::unique_ptr<profile::FrameCodec> codec_;
  std::unique_ptr<CanDevice> device_;
  int peer_ = -1;
  std::vector<can_frame> startup_;
  std::vector<can_frame> sent_ = std::vector<can_frame>(64);
  std::vector<int> own_heartbeats_ = std::vector<int>(1024);  // grant times [ms] of the
                                                              // firmware's heartbeats
 public:
  CanopenDeviceTest() {
    sent_.clear();
    own_heartbeats_.clear();
  }
};

// Each SDO in order, then NMT start (as after a re-boot: a drive whose configuration failed is
// never started).
TEST_F(CanopenDeviceTest, ConfiguresTheDriveWithEachSdoInOrderThenStartsIt) {
  std::string error;
  ASSERT_TRUE(Start(Routed(LoadProfile(), true), &error)) << error;
  ASSERT_EQ(startup_.size(), 4U);
  EXPECT_EQ(startup_[0].can_id, 0x605U);  // 0x6060:00 = -3 (1 byte)
  EXPECT_EQ(Bytes(startup_[0]), (std::vector<int>{0x2F, 0x60, 0x60, 0x00, 0xFD, 0, 0, 0}));
  EXPECT_EQ(Bytes(startup_[1]), (std::vector<int>{0x23, 0x16, 0x10, 0x01, 0x32, 0, 0x01, 0}));
  EXPECT_EQ(Bytes(startup_[2]), (std::vector<int>{0x2B, 0x17, 0x10, 0x00, 10, 0, 0, 0}));
  EXPECT_EQ(startup_[3].can_id, 0x000U);  // NMT start remote node 5
  EXPECT_EQ(Bytes(startup_[3]), (std::vector<int>{0x01, 5}));
  EXPECT_EQ(device_->sdo_downloads(), 3U);
}

TEST_F(CanopenDeviceTest, ARefusedSdoFailsTheStartUpNamingEntryAndAbortCode) {
  std::string error;
  EXPECT_FALSE(Start(Routed(LoadProfile(), true), &error, 0x6060, 0x06090030));
  EXPECT_EQ(error,
            "can: drive refused SDO 'modes of operation: current' 0x6060:00 = -3: abort "
            "0x06090030 value range of parameter exceeded");
  // Nothing after the refused download: no further SDO, no NMT start (the drive stays
  // pre-operational, not operational and unconfigured).
  ASSERT_EQ(startup_.size(), 1U);
  EXPECT_EQ(startup_[0].can_id, 0x605U);
}

// An answer for another object is no confirmation, and the error says it came.
TEST_F(CanopenDeviceTest, AnAnswerForAnotherObjectIsNamedNotTakenForSilence) {
  std::string error;
  EXPECT_FALSE(Start(Routed(LoadProfile(), false), &error, -1, 0, false, /*wrong=*/true));
  EXPECT_EQ(error,
            "can: drive (node 5) answered SDO 'modes of operation: current' 0x6060:00 = -3 with a "
            "response (0x60) for 0x6061:00, not for the object downloaded (a wrong index or "
            "subindex, or a reply that is no download confirmation), and no confirmation within "
            "100 ms");
  ASSERT_EQ(startup_.size(), 1U);  // no NMT start
}

TEST_F(CanopenDeviceTest, ASilentDriveFailsTheStartUp) {
  // Real time (the profile's 100 ms SDO timeout; lockstep would wait 2 s).
  std::string error;
  EXPECT_FALSE(Start(Routed(LoadProfile(), false), &error, -1, 0, /*silent=*/true));
  EXPECT_EQ(error,
            "can: drive (node 5) did not answer SDO 'modes of operation: current' 0x6060:00 = -3 "
            "within 100 ms (no SDO response on 0x585)");
}

TEST_F(CanopenDeviceTest, HeartbeatsBothWaysAndTheDrivesLossIsADriverFault) {
  std::string error;
  ASSERT_TRUE(Start(Routed(LoadProfile(), true), &error)) << error;
  // 100 ms with the drive operational (its heartbeat every 10 ms): no fault.
  for (int t = 1; t <= 100; ++t) {
    EXPECT_FALSE(Period(t, t % 10 == 0 ? co::kStateOperational : -1)) << t;
  }
  // The firmware's heartbeat: at the first period, then every 10 ms of granted time.
  EXPECT_EQ(own_heartbeats_, (std::vector<int>{1, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100}));
  EXPECT_EQ(device_->drive_state(), co::kStateOperational);
  // The drive falls silent after its heartbeat at 100 ms: a fault once more than 50 ms passed.
  for (int t = 101; t <= 150; ++t) EXPECT_FALSE(Period(t, -1)) << t;
  EXPECT_TRUE(Period(151, -1));
  EXPECT_TRUE(Period(152, -1));
  // Back: the fault clears with the first heartbeat.
  EXPECT_FALSE(Period(153, co::kStateOperational));
  // A drive that says pre-operational or stopped drives nothing: a fault while it says so.
  EXPECT_TRUE(Period(154, co::kStatePreOperational));
  EXPECT_TRUE(Period(155, co::kStateStopped));
  EXPECT_FALSE(Period(156, co::kStateOperational));
}

TEST_F(CanopenDeviceTest, ABootUpReconfiguresAndRestartsTheDriveSafeUntilOperational) {
  std::string error;
  ASSERT_TRUE(Start(Routed(LoadProfile(), true), &error)) << error;
  EXPECT_FALSE(Period(1, co::kStateOperational));
  EXPECT_TRUE(Period(2, co::kStateBootUp));  // the drive restarted
  EXPECT_EQ(device_->drive_boot_ups(), 1U);
  // The SDO list again, one request per answer, then NMT start; a fault all along.
  std::vector<can_frame> requests = Management();
  ASSERT_EQ(requests.size(), 1U);
  EXPECT_EQ(Bytes(requests[0]), (std::vector<int>{0x2F, 0x60, 0x60, 0x00, 0xFD, 0, 0, 0}));
  const std::vector<std::uint16_t> order = {0x6060, 0x1016, 0x1017};
  const std::vector<std::uint8_t> subs = {0, 1, 0};
  for (std::size_t i = 0; i < order.size(); ++i) {
    can_frame ack = Frame(co::SdoResponseId(5), {0, 0, 0, 0, 0, 0, 0, 0});
    co::EncodeSdoDownloadAck(order[i], subs[i], ack.data);
    PeerSend(ack);
    EXPECT_TRUE(Period(3 + static_cast<int>(i), -1));  // booted: a fault until operational
    requests = Management();
    ASSERT_EQ(requests.size(), 1U) << i;
    if (i + 1 < order.size()) {
      EXPECT_EQ(requests[0].can_id, co::SdoRequestId(5));
      EXPECT_EQ(requests[0].data[1] | requests[0].data[2] << 8, order[i + 1]);
    } else {
      EXPECT_EQ(requests[0].can_id, co::kNmtId);
      EXPECT_EQ(Bytes(requests[0]), (std::vector<int>{0x01, 5}));
    }
  }
  EXPECT_EQ(device_->sdo_downloads(), 6U);
  EXPECT_TRUE(Period(6, -1));                      // started, not yet operational
  EXPECT_FALSE(Period(7, co::kStateOperational));  // operational: the fault clears
}

TEST_F(CanopenDeviceTest, ARefusedReconfigurationHoldsTheFaultUntilTheNextBootUp) {
  std::string error;
  ASSERT_TRUE(Start(Routed(LoadProfile(), true), &error)) << error;
  EXPECT_FALSE(Period(1, co::kStateOperational));
  EXPECT_TRUE(Period(2, co::kStateBootUp));
  can_frame abort = Frame(co::SdoResponseId(5), {0, 0, 0, 0, 0, 0, 0, 0});
  co::EncodeSdoAbort(0x6060, 0, 0x06090030, abort.data);
  PeerSend(abort);
  EXPECT_TRUE(Period(3, -1));
  EXPECT_TRUE(Management().empty());  // no further SDO, no NMT start
  // A drive that starts itself anyway is not configured: still a fault.
  EXPECT_TRUE(Period(4, co::kStateOperational));
  EXPECT_TRUE(Period(14, co::kStateOperational));
  // The next boot-up tries again; answered, started, operational: driving.
  EXPECT_TRUE(Period(15, co::kStateBootUp));
  const std::uint16_t index[] = {0x6060, 0x1016, 0x1017};
  const std::uint8_t sub[] = {0, 1, 0};
  for (int i = 0; i < 3; ++i) {
    can_frame ack = Frame(co::SdoResponseId(5), {0, 0, 0, 0, 0, 0, 0, 0});
    co::EncodeSdoDownloadAck(index[i], sub[i], ack.data);
    PeerSend(ack);
    EXPECT_TRUE(Period(16 + i, -1));
  }
  EXPECT_FALSE(Period(19, co::kStateOperational));
}

// The shipped profile with SYNC every 2 ms, no SDO list and no NMT start (a drive that keeps
// its settings and starts itself).
std::shared_ptr<const profile::CanProfile> SyncProfile() {
  std::ifstream in(kProfile);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  text = text.substr(0, text.find("[[canopen.sdo]]"));
  const std::string dir = std::string(MRD_SOURCE_DIR) + "/firmware/profiles/";
  for (const std::string file : {"canopen-drive.dbc", "canopen-coil.csv"}) {
    text.replace(text.find("\"" + file + "\""), file.size() + 2, "\"" + dir + file + "\"");
  }
  text.replace(text.find("sync_period_ms = 0"), 18, "sync_period_ms = 2");
  text.replace(text.find("nmt_start = true"), 16, "nmt_start = false");
  const std::string path = ::testing::TempDir() + "/canopen-sync.toml";
  std::ofstream(path) << text;
  return LoadProfile(path);
}

TEST_F(CanopenDeviceTest, SyncEveryPeriodAndNoStartUpFramesWhenNoneAreConfigured) {
  std::string error;
  ASSERT_TRUE(Start(Routed(SyncProfile(), true), &error)) << error;
  EXPECT_TRUE(startup_.empty());  // no NMT start, no SDO
  std::vector<int> syncs;
  for (int t = 1; t <= 10; ++t) {
    EXPECT_FALSE(Period(t, co::kStateOperational));
    for (const can_frame& f : sent_) {
      if (f.can_id == co::kSyncId) {
        EXPECT_EQ(f.len, 0);
        syncs.push_back(t);
      }
    }
  }
  // At the first period, then on the 2 ms grid of granted time from the activation (t = 0).
  EXPECT_EQ(syncs, (std::vector<int>{1, 2, 4, 6, 8, 10}));
}

TEST(CanopenNoAllocation, GuardSeesAnAllocation) {
  test::AllocationGuard guard;
  std::string s(100, 'x');
  asm volatile("" : : "g"(s.data()) : "memory");
  EXPECT_GE(guard.count(), 1U);
}

TEST_F(CanopenDeviceTest, CanopenLoopPeriodsAllocateNothing) {
  std::string error;
  ASSERT_TRUE(Start(Routed(LoadProfile(), true), &error)) << error;
  EXPECT_FALSE(Period(1, co::kStateOperational));  // first use of the containers
  test::AllocationGuard guard;
  int faults = 0;
  for (int t = 2; t <= 400; ++t) {
    // Operational heartbeats, a silence (loss), a boot-up with its re-configuration answered,
    // foreign CANopen frames (another node's heartbeat, SYNC, NMT).
    int state = t % 10 == 0 ? co::kStateOperational : -1;
    if (t > 100 && t < 200) state = -1;
    if (t == 250) state = co::kStateBootUp;
    if (t > 250 && t <= 253) {
      can_frame ack = Frame(co::SdoResponseId(5), {0, 0, 0, 0, 0, 0, 0, 0});
      const std::uint16_t index[] = {0x6060, 0x1016, 0x1017};
      const std::uint8_t sub[] = {0, 1, 0};
      co::EncodeSdoDownloadAck(index[t - 251], sub[t - 251], ack.data);
      PeerSend(ack);
    }
    if (t == 300) {
      PeerSend(Frame(co::HeartbeatId(16), {co::kStateOperational}));
      PeerSend(Frame(co::kSyncId, {}));
      PeerSend(Frame(co::kNmtId, {0x01, 16}));
    }
    faults += Period(t, state) ? 1 : 0;
  }
  EXPECT_EQ(guard.count(), 0U);
  EXPECT_GT(faults, 50);  // the loss and the boot-up really ran
  EXPECT_EQ(device_->drive_boot_ups(), 1U);
  EXPECT_EQ(device_->sdo_downloads(), 6U);
  EXPECT_EQ(device_->drive_state(), co::kStateOperational);
  EXPECT_EQ(device_->counters().rx_rejected, 0U);  // foreign CANopen frames are not refused
}

}  // namespace
}  // namespace mrd::firmware
