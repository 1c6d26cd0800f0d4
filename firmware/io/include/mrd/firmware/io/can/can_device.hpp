#pragma once
// The CAN field device: sensor frames in, driver command / heartbeat / status frames out, in
// the messages and signals of a device profile (mrd/profile/can_profile.hpp, docs/devices.md;
// the built-in mrd-native profile is docs/mrd.dbc), over a SocketCAN CAN_RAW socket with
// receive filters derived from the profile, or a node of the local frame bus (mrd-canbus);
// only the fd's creation differs (mrd/canbus/socket.hpp), the receive/transmit code is the
// same.
//
// Why non-blocking fds in the tick, not an I/O thread: a CAN frame is one 16-byte read or
// write on a socket that never blocks (O_NONBLOCK), a few microseconds each, and the kernel's
// socket buffers already are the mailbox between the bus and the loop. The tick drains at most
// kMaxFramesPerRead frames and queues at most a handful, so its work is bounded; a thread would
// add a hand-over (and its latency and scheduling jitter) without removing any wait. (Modbus is
// different: libmodbus blocks for a whole request/reply, so it lives on a thread.)
//
// Per period (Read, Write, PublishStatus, Deactivate): what is read, refused, counted and
// sent, floods, reconnects and deadlines are documented in one place, docs/can_bus.md,
// "The firmware's CAN device"; keep it current with this code.
//
// CANopen (the profile's [canopen]: a CiA 301 drive; can_device_canopen.cpp):
//   Activate  sends NMT "start remote node" to the drive (nmt_start), then each start-up SDO
//          download in order, each waiting for the drive's answer (sdo_timeout_ms; at least
//          2 s in lockstep, where the harness answers on wall time): an abort or no answer
//          fails Activate with the entry, index:subindex, value, abort code and its CiA 301
//          meaning, and the firmware does not start.
//   Read   consumes the drive's heartbeat (0x700 + node): no heartbeat for
//          drive_heartbeat_timeout_ms (device time), or a state other than operational, sets
//          the frame's fault_line (the watchdog's fault_line cause, as a driver status fault
//          does). A boot-up (state 0x00: the drive restarted and lost its configuration) makes
//          the device download the SDO list again, one request per answer (frames built at
//          construction, no allocation), then send NMT start; the fault holds until the drive
//          reports operational. Other nodes' NMT, SYNC, EMCY, SDO and heartbeat frames are
//          read over (not counted as refused).
//   Write  produces the firmware's heartbeat (0x700 + own node, state operational) every
//          heartbeat_ms and SYNC (0x080) every sync_period_ms, after the command (device time).
//          Both stop when the firmware dies: the drive's heartbeat consumer then acts.
//
// Lockstep (config.lockstep, [loop] clock = "grant"): the device is also the loop's
// TimeGrantSource (grant_clock.hpp). WaitGrant handles frames as they come (one ppoll on the
// fd with the remaining timeout, then non-blocking reads) and returns at the first valid
// frame carrying the grant role (mrd-native: TimeGrant). Time is then the granted time: sensor
// values are stamped with the grant that follows them (the harness sends a step's sensor
// frames, then its grant), heartbeat and status are scheduled in granted time. A wait that
// ends without a grant is no fault: the clock keeps waiting (grant_clock.hpp).
//
// Several channels on one bus ([channels] can_profiles): one device per channel, each with its
// own profile and its own socket (SocketCAN: a CAN_RAW socket each; the local bus: a node
// each). Channel 0's device produces the firmware node's CANopen heartbeat and SYNC
// (config.node_frames; the others' do not), each device starts and watches its own drive. In
// lockstep channel 0's device is the grant source; the others are followers
// (config.grant_follower): the harness sends each node a step's sensor frames then the grant,
// but hands them to one node after another, so when channel 0 wakes on its grant a follower's
// socket may not have its frames yet. A follower's Read therefore first handles its frames as
// they come (non-blocking reads, one ppoll on the fd while it is empty; no polling sleeps)
// until its own socket has delivered a grant >= the tick's time (t.loop_ns), at most
// config.follower_wait_ns of wall time or until config.stop is set (then the read faults:
// timeout); the grant ends the
// drain, so every channel reads exactly the tick's samples, however the process or the relay
// is scheduled (a stop of the firmware only delays it). The deadline is checked only with the
// socket empty, so a stopped process (SIGSTOP) that resumes past it reads what came meanwhile.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/io/fault_reset.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/seqlock.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::firmware {

class CanDevice final : public BusDevice, public TimeGrantSource {
 public:
  // A period's drain budget. A backlog a stall left (a full receive queue: about 270 frames on
  // the local bus and with SocketCAN's default buffer) is drained in a few periods (its samples
  // are old: stale); a flood costs a tick at most this many reads (about 2.7 us each on the
  // 2-core build VM: 350 us).
  static constexpr int kMaxFramesPerRead = 128;
  // Refused frames per period beyond which the bus counts as flooded (a healthy bus refuses
  // a frame now and then: a corrupt or repeated one per sensor frame at most).
  static constexpr int kMaxRejectsPerRead = 16;
  // How long the bus counts as flooded after the last period with too many refused frames
  // [ns] (device time: granted time in lockstep).
  static constexpr std::int64_t kFloodHoldNs = 100'000'000;
  // A drain budget of frames that arrived within this span is a flood (over 25 frames/ms: a
  // healthy bus carries about 3, a 1 Mbit/s CAN bus at most 8) [ns].
  static constexpr std::int64_t kFloodSpanNs = 5'000'000;
  static constexpr std::int64_t kReconnectInterval = 100'000'000;  // [ns]

  // Opens from config.interface (SocketCAN) or config.local_bus at Configure. The profile is
  // config.can_profile (loaded with the configuration), else the built-in mrd-native one.
  explicit CanDevice(const CanConfig& config);
  // Runs on an fd already open (e.g. one end of a socketpair); it cannot be reopened.
  CanDevice(const CanConfig& config, int fd);
  ~CanDevice() override { Deactivate(); }

  const char* name() const override { return config_.name; }
  FaultCause fault_cause() const override { return FaultCause::kCanBus; }
  bool Configure(std::string* error) override;
  bool Activate(std::string* error) override;
  void Deactivate() override;
  IoStatus Read(const IoTime& t, SensorFrame* frame, IoError* why) override;
  IoStatus Write(const IoTime& io, const DriverCommand& cmd, IoError* why) override;
  void PublishStatus(const IoTime& io, const TelemetrySnapshot& stats) override;
  DeviceCounters counters() const override { return published_.Read(); }
  // Lockstep only (config.lockstep); bounded wait, no allocation.
  bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) override;
  TimeGrantSource* grant_source() override {
    return config_.lockstep && !follower() ? this : nullptr;
  }

  std::uint32_t driver_faults() const { return driver_faults_; }
  double driver_current() const { return driver_current_; }  // [driver unit], latest status
  const profile::CanProfile& can_profile() const { return *profile_; }
  // CANopen: the drive's NMT state from its latest heartbeat (kDriveStateUnknown before one),
  // boot-ups seen since start, SDO downloads done (start-up and after boot-ups).
  static constexpr std::uint8_t kDriveStateUnknown = 0xFF;
  std::uint8_t drive_state() const { return drive_state_; }
  std::uint64_t drive_boot_ups() const { return drive_boot_ups_; }
  std::uint64_t sdo_downloads() const { return sdo_downloads_; }

 private:
  void Index();  // role and message tables of the profile, receive filters (construction)
  int Open(std::string* error) const;
  void TryReconnect(std::int64_t now);
  void Reject(protocol::can::Reject reason);
  void Count(IoError error);
  bool Handle(const can_frame& f, std::int64_t stamp, std::int64_t wall_ns);
  // Several channels in lockstep: this device is not the loop's grant source.
  bool follower() const { return config_.lockstep && config_.grant_follower; }
  // A follower's Read: handles frames as they come (ppoll between them) until its socket has
  // delivered a grant >= loop_ns (true; that grant then ends the Read's drain), at most
  // config.follower_wait_ns of wall time; false on a timeout, a stop request (config.stop), the
  // bus gone or a flood. *fresh: a routed input came.
  bool FollowGrant(std::int64_t loop_ns, bool* fresh);
  void Grant(double time_us);
  // The device's time: CLOCK_MONOTONIC, or the latest granted time in lockstep.
  std::int64_t Now(std::int64_t wall_ns) const;
  // Queues one frame; false (and counted) when it failed.
  bool Send(const can_frame& f, std::int64_t now);
  bool Sent(canbus::CanResult r);  // a send's result counted: true when kOk
  void SendStatus(const IoTime& io, const TelemetrySnapshot& stats);  // when due
  // Real time: the latest motion sample (routed here) is older than max_age at now.
  bool MotionTooOld(std::int64_t now) const;
  // Encodes and queues the command messages; false when a send failed or a value was refused.
  // reset: the fault_reset bit is 1 in them (never in the shutdown command).
  bool SendCommand(const DriverCommand& cmd, std::int64_t now, bool reset);
  void Publish() { published_.Write(counters_); }
  // CANopen (can_device_canopen.cpp). The SDO frames and filters (construction).
  void IndexCanopen();
  // NMT start and the SDO list, each answered (Activate; waits, allocates the error text).
  bool StartCanopen(std::string* error);
  // A frame of the drive's heartbeat or SDO answer (true: consumed).
  bool HandleCanopen(const can_frame& f, std::int64_t wall_ns);
  // Another node's CANopen management frame (NMT, SYNC, EMCY, SDO, heartbeat id ranges).
  bool IsCanopenManagement(const can_frame& f) const;
  void SendNmtStart(std::int64_t now);
  // The in-loop re-configuration after a boot-up: the next SDO request, or NMT start.
  void ReconfigureNext(std::int64_t now);
  // The heartbeat and SYNC schedules (Write).
  bool ProduceCanopen(std::int64_t now, std::int64_t t);
  // fault_line from the drive's heartbeat; the re-configuration's answer timeout (Read).
  bool DriveFault(std::int64_t wall_ns);

  CanConfig config_;
  std::shared_ptr<const profile::CanProfile> profile_;
  profile::FrameCodec codec_;
  profile::CommandMap command_;      // the profile's, with this device's slew state
  std::vector<can_filter> filters_;  // SocketCAN receive filters (the profile's inputs)
  // Per profile message: the input roles it carries (bit i = CanIn i); the messages the
  // firmware sends, by kind.
  std::array<std::uint16_t, profile::FrameCodec::kMaxMessages> rx_roles_{};
  std::vector<int> command_msgs_, heartbeat_msgs_, status_msgs_;
  int status_driver_msg_ = -1;  // the message carrying driver_faults (its timeout applies)
  bool reopenable_;
  bool active_ = false;
  canbus::CanIface iface_;
  std::uint32_t last_seq_ = 0;
  std::uint32_t driver_faults_ = 0;
  double driver_current_ = 0.0;
  bool fault_input_ = false;           // the fault_line role, non-zero
  std::int64_t driver_status_ns_ = 0;  // device time of the latest driver status
  int rejects_since_read_ = 0;
  std::int64_t flood_until_ns_ = 0;  // a babbling node's fault holds until then (Now())
  std::array<Stamped, profile::kNumCanIn> values_{};  // latest value of each input role
  // Lockstep: the latest granted time, values waiting for their grant's stamp (bit i = role
  // i), fresh values seen by WaitGrant since the last Read.
  std::int64_t granted_ns_ = 0;
  bool got_grant_ = false;
  std::uint16_t unstamped_ = 0;
  bool fresh_in_wait_ = false;
  // Lockstep: a period (Read ... PublishStatus) is going on; its frames are held until its end
  // (Write holds, PublishStatus releases). Not for a Write outside a period (the loop's
  // shut-down): that goes out at once.
  bool in_period_ = false;
  std::int64_t next_heartbeat_ns_ = 0, next_status_ns_ = 0, next_reconnect_ns_ = 0;
  // fault_reset: the firmware's active causes (the latest PublishStatus; all until the first:
  // no reset before the firmware says it is clean), the edges' rule.
  unsigned active_causes_ = ~0U;
  FaultResetRule reset_rule_;
  DeviceCounters counters_;
  Seqlock<DeviceCounters> published_;
  // CANopen ([canopen] of the profile; nullptr without).
  const profile::CanopenConfig* canopen_ = nullptr;
  std::vector<can_frame> sdo_frames_;  // the SDO list's requests, in order
  std::uint8_t drive_state_ = kDriveStateUnknown;
  std::int64_t drive_heartbeat_ns_ = 0;     // device time of the drive's latest heartbeat
  bool drive_heartbeat_unstamped_ = false;  // lockstep: stamped by the grant that follows
  std::int64_t next_own_heartbeat_ns_ = 0, next_sync_ns_ = 0;
  // Re-configuration after a boot-up: the SDO entry awaiting its answer (-1: none), since.
  int reconfig_sdo_ = -1;
  std::int64_t reconfig_sent_ns_ = 0;
  bool reconfig_failed_ = false;  // refused or unanswered: a fault until the next boot-up
  std::uint64_t drive_boot_ups_ = 0, sdo_downloads_ = 0;
};

}  // namespace mrd::firmware
