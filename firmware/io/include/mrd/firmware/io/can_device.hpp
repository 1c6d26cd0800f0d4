#pragma once
// The CAN field device: sensor frames in, driver command / heartbeat / status frames out
// (docs/mrd.dbc, codec in mrd/protocol/can_codec.hpp), over a SocketCAN CAN_RAW socket with
// receive filters or a node of the local frame bus (mrd-canbus); only the fd's creation
// differs (mrd/canbus/socket.hpp), the receive/transmit code is the same.
//
// Why non-blocking fds in the tick, not an I/O thread: a CAN frame is one 16-byte read or
// write on a socket that never blocks (O_NONBLOCK), a few microseconds each, and the kernel's
// socket buffers already are the mailbox between the bus and the loop. The tick drains at most
// kMaxFramesPerRead frames and queues at most a handful, so its work is bounded; a thread would
// add a hand-over (and its latency and scheduling jitter) without removing any wait. (Modbus is
// different: libmodbus blocks for a whole request/reply, so it lives on a thread.)
//
// Per period:
//   Read   flushes queued frames, drains the received ones to the newest (at most
//          kMaxFramesPerRead): each is decoded (ID, DLC, checksum, range) and its rolling
//          counter checked; rejects are counted (rejected_frame / crc / bad_value) and change
//          nothing. Accepted sensor values keep their arrival stamps (CanIface: the relay's
//          or the kernel's, not the read's), so data that waited in the socket (a stalled
//          process, a backlog) show their true age to the watchdog. A flood — more than
//          kMaxRejectsPerRead frames refused since the last Read (a babbling node), or a
//          budget of frames that arrived within kFloodSpanNs with more still waiting — is
//          kFault (overflow, counted per period): the can_bus cause, the safe state; after
//          refused frames it holds for kFloodHoldNs after the last such period. A backlog a
//          stall of the firmware left is no flood: its samples are just old. A lost bus (EOF, reset, network down, bus-off)
//          is kFault (disconnected / bus_off) — the can_bus cause too — and the device
//          reopens its fd every kReconnectInterval from the tick (socket + connect/bind: no
//          allocation, no wait). Silence (a sender that stopped) is kNoData: the stamps go
//          stale and the watchdog's stale-sensor cause takes over. A DriverStatus with any
//          fault bit sets the frame's fault_line (the watchdog's fault_line cause, as the
//          Modbus sensor block's driver-fault bit does) until a status without one.
//   Write  queues the driver command (set-point, enable, safe flag, echo of the latest sensor
//          seq) with the deadline tx_deadline, and the heartbeat at heartbeat_period; a frame
//          not written by its deadline is dropped (timeout). In real time a driving (non-safe)
//          command is not sent either when the SensorMotion sample it echoes is older than
//          max_age by then (a tick held up after the watchdog's check: preempted, stopped):
//          timeout, and the loop commands the safe state instead. A failed or dropped send is
//          kFault.
//   PublishStatus  the firmware status frame at status_period.
// Frames of the firmware's own IDs heard from another node are ignored; the driver's status
// frame is checked and counted (its fault bits and current are kept: driver_faults(),
// driver_current()).
//
// Lockstep (config.lockstep, [loop] clock = "grant"): the device is also the loop's
// TimeGrantSource (grant_clock.hpp). WaitGrant handles frames as they come (one ppoll on the
// fd with the remaining timeout, then non-blocking reads) and returns at the first valid
// TimeGrant frame. Time is then the granted time: sensor values are stamped with the grant
// that follows them (the harness sends a step's sensor frames, then its grant), heartbeat and
// status are scheduled in granted time. A wait that times out is a missed grant: the next Read
// is kFault (timeout, the can_bus cause), so the loop commands the safe state for that period.

#include <cstdint>
#include <string>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/firmware/bus_device.hpp"
#include "mrd/firmware/grant_clock.hpp"
#include "mrd/firmware/seqlock.hpp"
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

  // Opens from config.interface (SocketCAN) or config.local_bus at Configure.
  explicit CanDevice(const CanConfig& config);
  // Runs on an fd already open (e.g. one end of a socketpair); it cannot be reopened.
  CanDevice(const CanConfig& config, int fd);
  ~CanDevice() override { Deactivate(); }

  const char* name() const override { return "can"; }
  FaultCause fault_cause() const override { return FaultCause::kCanBus; }
  bool Configure(std::string* error) override;
  bool Activate(std::string* error) override;
  void Deactivate() override;
  IoStatus Read(SensorFrame* frame, IoError* why) override;
  IoStatus Write(const DriverCommand& cmd, IoError* why) override;
  void PublishStatus(const TelemetrySnapshot& stats) override;
  DeviceCounters counters() const override { return published_.Read(); }
  // Lockstep only (config.lockstep); bounded wait, no allocation.
  bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) override;
  TimeGrantSource* grant_source() override { return config_.lockstep ? this : nullptr; }

  const canbus::CanStats& bus_stats() const { return iface_.stats(); }
  std::uint8_t driver_faults() const { return driver_faults_; }
  double driver_current() const { return driver_current_; }  // [A], latest DriverStatus

 private:
  int Open(std::string* error) const;
  void TryReconnect(std::int64_t now);
  void Reject(protocol::can::Reject reason);
  void Count(IoError error);
  bool Handle(const can_frame& f, std::int64_t stamp);
  bool HandleGrant(const can_frame& f);
  // The device's time: CLOCK_MONOTONIC, or the latest granted time in lockstep.
  std::int64_t Now() const;
  // Queues one frame; false (and counted) when it failed.
  bool Send(const can_frame& f, std::int64_t now);
  // Real time: the latest SensorMotion sample (routed here) is older than max_age at now.
  bool MotionTooOld(std::int64_t now) const;
  void Publish() { published_.Write(counters_); }

  CanConfig config_;
  bool reopenable_;
  bool active_ = false;
  canbus::CanIface iface_;
  protocol::can::CounterCheck motion_check_, force_check_, status_check_;
  std::uint8_t command_counter_ = 0, heartbeat_counter_ = 0, status_sequence_ = 0;
  std::uint16_t last_seq_ = 0;
  std::uint8_t driver_faults_ = 0;
  double driver_current_ = 0.0;
  int rejects_since_read_ = 0;
  std::int64_t flood_until_ns_ = 0;  // a babbling node's fault holds until then (Now())
  Stamped velocity_, displacement_, demand_, body_velocity_, force_;
  // Lockstep: the latest granted time, sensor values waiting for their grant's stamp, a grant
  // missed since the last Read, fresh values seen by WaitGrant since the last Read.
  protocol::can::CounterCheck grant_check_;
  std::int64_t granted_ns_ = 0;
  bool got_grant_ = false;
  bool unstamped_motion_ = false, unstamped_force_ = false;
  bool fresh_in_wait_ = false;
  std::int64_t next_heartbeat_ns_ = 0, next_status_ns_ = 0, next_reconnect_ns_ = 0;
  DeviceCounters counters_;
  Seqlock<DeviceCounters> published_;
};

}  // namespace mrd::firmware
