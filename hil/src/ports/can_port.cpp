// The harness's CAN side (plant_port.hpp), in the messages of a device profile read from the
// other side (mrd/profile/can_profile.hpp; default the built-in mrd-native: SensorMotion,
// SensorForce, TimeGrant, DriverStatus out; DriverCommand, Heartbeat, FirmwareStatus in): the
// plant's sensor messages every step; the simulated driver hears the command and heartbeat
// messages and sends its status message at the message's period (the DBC's GenMsgCycleTime or
// the profile's period_ms; 100 ms without either) and at once when its fault bits change: the
// current of the latest command (its set-point over a kCoilOhms coil while it enables the
// coil, else 0 A) and the driver's fault (the step's fault_line or driver_fault: the
// scenario's faults of those kinds, `mrd-hil serve --fault-line`) as the overcurrent bit
// (docs/mrd.dbc). Commands are
// timed by their bus stamps (when the firmware sent them). Endpoint: a local frame bus socket
// path (contains '/') or a SocketCAN interface. On a local bus path nobody serves yet (no socket,
// or one left by a dead relay), the port runs the relay itself on a thread: the harness then owns
// the bus, and the firmware loses it when the harness exits (the peer-restart test relies on that).
// With a CANopen profile ([canopen]) the simulated driver is a CiA 301 node: it boots into
// pre-operational, follows NMT (start -> operational, stop, pre-operational, resets -> boot-up
// frame), answers expedited SDO downloads (accepted; RefuseSdo makes it abort one), produces
// its heartbeat (0x700 + node, 0x05) in operational state every producer period (the SDO to
// 0x1017 sets it; default kDriveHeartbeatSteps), unless the step's drive_heartbeat_loss fault
// holds, and sends its status PDO only in operational. The firmware's CANopen heartbeat
// (0x700 + own node) is the heartbeat the driver watches.
#include <linux/can.h>
#include <poll.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <ctime>
#include <memory>
#include <thread>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/canopen_codec.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::hil {
namespace {

namespace pc = protocol::can;

constexpr int kMaxFramesPerPoll = 64;
constexpr std::int64_t kTxDeadlineNs = 1'000'000;  // one plant period
constexpr std::int64_t kReconnectNs = 100'000'000;
// The driver status period when neither the DBC (GenMsgCycleTime) nor the profile (period_ms)
// gives one: 100 ms, mrd-native's DriverStatus (docs/mrd.dbc).
constexpr std::uint32_t kStatusPeriodSteps = 100;
constexpr double kCoilOhms = 5.0;  // simulated coil (e.g. a Lord RD-1005-3: about 5 ohm)
constexpr std::uint32_t kDriveHeartbeatSteps = 10;  // CANopen drive: default producer period

namespace co = profile::canopen;

namespace pf = profile;
using pf::CanIn;
using pf::CanOut;

// The step number an echo of `bits` bits stands for: the latest one published with those low
// bits (the echo never runs ahead of what was published).
std::uint32_t ExpandEcho(std::uint32_t echo, std::uint32_t last_published, int bits) {
  if (bits >= 32) return echo;
  const std::uint32_t span = std::uint32_t{1} << bits;
  std::uint32_t s = (last_published & ~(span - 1U)) | echo;
  if (s > last_published && s >= span) s -= span;
  return s;
}

std::shared_ptr<const pf::CanProfile> ProfileOrNative(std::shared_ptr<const pf::CanProfile> p) {
  if (p != nullptr) return p;
  return std::shared_ptr<const pf::CanProfile>(&pf::NativeCanProfile(),
                                               [](const pf::CanProfile*) {});
}

// A signal's extreme raw values (the NaN code is the most negative, as in the native DBC).
std::int64_t MaxRaw(const protocol::SignalLayout& l) {
  return l.is_signed ? (std::int64_t{1} << (l.length - 1)) - 1
                     : static_cast<std::int64_t>((std::uint64_t{1} << l.length) - 1U);
}
std::int64_t MinRaw(const protocol::SignalLayout& l) {
  return l.is_signed ? -(std::int64_t{1} << (l.length - 1)) : 0;
}

class CanPort;
// The relay's one tap handed to several ports on it, in the order they were made (each keeps
// the frames its profile listens to).
struct TapFanOut {
  std::vector<CanPort*> ports;
  static void Tap(void* context, const void* frame, std::int64_t stamp_ns);
};

class CanPort final : public PlantPort {
 public:
  CanPort(std::string endpoint, std::shared_ptr<const pf::CanProfile> profile)
      : endpoint_(std::move(endpoint)),
        profile_(ProfileOrNative(std::move(profile))),
        codec_(*profile_) {
    Index();
  }
  // An in-process node of a relay this process runs (the harness owns the bus). fan: several
  // ports on the relay (one per corner), its tap handed to each (nullptr: this port's alone).
  CanPort(canbus::LocalBusRelay& relay, std::shared_ptr<const pf::CanProfile> profile,
          std::shared_ptr<TapFanOut> fan = nullptr)
      : relay_(&relay),
        fan_(std::move(fan)),
        profile_(ProfileOrNative(std::move(profile))),
        codec_(*profile_) {
    Index();
    if (fan_ != nullptr) {
      fan_->ports.push_back(this);
      relay.SetTap(&TapFanOut::Tap, fan_.get());
    } else {
      relay.SetTap(&CanPort::Tap, this);
    }
  }
  ~CanPort() override {
    if (fan_ != nullptr) {
      fan_->ports.erase(std::find(fan_->ports.begin(), fan_->ports.end(), this));
      if (fan_->ports.empty()) relay_->SetTap(nullptr, nullptr);
    } else if (relay_ != nullptr) {
      relay_->SetTap(nullptr, nullptr);
    }
    Close();
  }

  // Frames the relay's socket nodes sent, with their bus stamps (called from
  // LocalBusRelay::Step; the fan-out calls every port's).
  static void Tap(void* context, const void* frame, std::int64_t stamp_ns) {
    auto* self = static_cast<CanPort*>(context);
    if (!self->relay_open_) return;
    can_frame f;
    std::memcpy(&f, frame, sizeof f);
    if (!self->Wanted(f)) return;
    if (self->rx_count_ == self->rx_.size()) {
      ++self->rejected_;  // overflow: as a full controller FIFO
      return;
    }
    const std::size_t slot = (self->rx_head_ + self->rx_count_) % self->rx_.size();
    self->rx_[slot].frame = f;
    self->rx_[slot].stamp = stamp_ns;
    ++self->rx_count_;
  }

  const char* name() const override { return "can"; }

  bool Open(std::string* error) override {
    if (relay_ != nullptr) {
      relay_open_ = true;
      return true;
    }
    if (!canbus::IsLocalBusPath(endpoint_)) {
      const int fd =
          canbus::OpenSocketCan(endpoint_.c_str(), filters_.data(), filters_.size(), error);
      if (fd < 0) return false;
      iface_.Attach(fd);
      return true;
    }
    int fd = canbus::OpenLocalBusNode(endpoint_.c_str(), nullptr);
    if (fd < 0) {
      if (!own_relay_.Open(endpoint_, error)) return false;
      relay_stop_.store(false);
      relay_thread_ = std::thread([this] { own_relay_.Run(relay_stop_); });
      fd = canbus::OpenLocalBusNode(endpoint_.c_str(), error);
      if (fd < 0) return false;
    }
    iface_.Attach(fd);
    return true;
  }

  void Publish(const SensorOutput& out) override {
    // The step's frames go to the bus together (the relay's Hold): lockstep, with the grant
    // (SendGrant releases them); else at the end of this call.
    struct Batch {
      canbus::LocalBusRelay* relay;
      bool until_grant;
      ~Batch() {
        if (relay != nullptr && !until_grant) relay->Release();
      }
    } batch{relay_, lockstep_};
    if (relay_ != nullptr) relay_->Hold();
    last_published_ = out.seq;
    const std::int64_t now = common::MonotonicNs();
    if (!IsOpen()) Reconnect(now);
    if (!IsOpen()) return;
    if (canopen_ != nullptr) PublishDriveHeartbeat(out, now);
    PublishDriverStatus(out, now);  // the driver's node: not subject to the sensors' faults
    if (out.fault == SensorFault::kDrop) return;
    if (out.fault == SensorFault::kStall) {
      // The same frames again: counters repeat, the firmware refuses them.
      if (have_last_) {
        for (const int m : sensor_msgs_) {
          if ((out.sample.has_chassis || !IsIn(chassis_msgs_, m)) &&
              (out.sample.has_structure || !IsIn(structure_msgs_, m))) {
            SendFrame(last_[static_cast<std::size_t>(m)], now);
          }
        }
      }
      return;
    }
    const pf::SignalRef velocity = profile_->inputs[static_cast<std::size_t>(CanIn::kVelocity)];
    bool all_ok = true;
    for (const int m : sensor_msgs_) {
      // Chassis-only messages when the plant has a chassis (the damper plant has none: its
      // runs keep the frame set they always had).
      if (!out.sample.has_chassis && IsIn(chassis_msgs_, m)) continue;
      if (!out.sample.has_structure && IsIn(structure_msgs_, m)) continue;  // likewise
      can_frame f{};
      codec_.Begin(m, &f);
      bool ok = true;
      const auto set = [&](CanIn role, double v) { ok = SetRole(role, v, m, &f) && ok; };
      const bool bad_v = out.fault == SensorFault::kOutOfRange || out.fault == SensorFault::kNan;
      set(CanIn::kVelocity, bad_v ? 0.0 : out.sample.v);
      set(CanIn::kDisplacement, out.sample.x);
      set(CanIn::kDemand, out.sample.demand);
      set(CanIn::kBodyVelocity, out.sample.body_velocity);
      set(CanIn::kForce, out.sample.force);
      set(CanIn::kFaultLine, out.fault_line ? 1.0 : 0.0);
      set(CanIn::kBodyAcceleration, out.sample.body_acceleration);
      set(CanIn::kWheelVelocity, out.sample.wheel_velocity);
      set(CanIn::kFloorAcceleration1, out.sample.floor_acceleration[0]);
      set(CanIn::kFloorAcceleration2, out.sample.floor_acceleration[1]);
      set(CanIn::kFloorAcceleration3, out.sample.floor_acceleration[2]);
      const pf::SignalRef seq = profile_->inputs[static_cast<std::size_t>(CanIn::kSensorSeq)];
      if (seq.message == m) {
        protocol::InsertRaw(f.data, profile_->Layout(seq),
                            static_cast<std::int64_t>(out.seq & static_cast<std::uint32_t>(MaxRaw(
                                                                    profile_->Layout(seq)))));
      }
      if (!ok) {  // not representable: this message is not sent (as the native encoder refuses)
        all_ok = false;
        continue;
      }
      if (bad_v && velocity.message == m) {
        // A raw velocity outside the DBC's range (the field's largest code; the most negative,
        // "not a number"), sealed with a valid checksum.
        const auto& l = profile_->Layout(velocity);
        protocol::InsertRaw(f.data, l, out.fault == SensorFault::kNan ? MinRaw(l) : MaxRaw(l));
      }
      codec_.Seal(m, &f);
      if (out.fault == SensorFault::kCorrupt) f.data[f.len > 1 ? 1 : 0] ^= 0x10U;  // after sealing
      const bool sent = SendFrame(f, now) == canbus::CanResult::kOk;
      if (sent && (velocity.message == m || velocity.message < 0) && m == sensor_msgs_.front()) {
        ++published_;
      }
      last_[static_cast<std::size_t>(m)] = f;
    }
    have_last_ = all_ok && !sensor_msgs_.empty();
  }

  bool SendGrant(std::int64_t t_ns) override {
    const bool sent = SendGrantFrame(t_ns);
    if (relay_ != nullptr) relay_->Release();  // the step's sensor frames (Publish) and grant
    return sent;
  }
  bool SendGrantFrame(std::int64_t t_ns) {
    const std::int64_t now = common::MonotonicNs();
    if (!IsOpen()) Reconnect(now);
    if (!IsOpen()) return false;
    const pf::SignalRef grant = profile_->inputs[static_cast<std::size_t>(CanIn::kGrant)];
    if (!grant.mapped()) return false;  // the profile carries no grant: real time only
    can_frame f{};
    codec_.Begin(grant.message, &f);
    if (codec_.Set(&f, grant, static_cast<double>(t_ns / 1000)) != protocol::SignalError::kNone) {
      return false;
    }
    codec_.Seal(grant.message, &f);
    return SendFrame(f, now) == canbus::CanResult::kOk;
  }

  void Wait(std::int64_t timeout_ns) override {
    if (relay_ != nullptr) {
      relay_->Step(static_cast<int>((timeout_ns + 999'999) / 1'000'000));
      return;
    }
    if (!iface_.is_open()) {
      PlantPort::Wait(timeout_ns);
      return;
    }
    if (iface_.buffered() > 0) return;  // read ahead: Poll has them now
    const timespec ts{static_cast<time_t>(timeout_ns / 1'000'000'000),
                      static_cast<long>(timeout_ns % 1'000'000'000)};
    pollfd p{iface_.fd(), POLLIN, 0};
    (void)ppoll(&p, 1, &ts, nullptr);
  }

  void Poll(DriverInput* in) override {
    if (!IsOpen()) return;
    for (int k = 0; k < kMaxFramesPerPoll; ++k) {
      can_frame f{};
      std::int64_t stamp = 0;
      const canbus::CanResult r = ReceiveFrame(&f, &stamp);
      if (r == canbus::CanResult::kEmpty || r == canbus::CanResult::kDisconnected) break;
      if (r != canbus::CanResult::kOk) {
        ++rejected_;
        continue;
      }
      const bool command_before = in->has_command;
      Handle(f, stamp, in);
      // Lockstep: a tick's messages end with its status (its command, when the profile has
      // no status message); what follows belongs to the next tick (or the firmware's
      // shutdown) and waits for the next Poll.
      if (lockstep_ && in->has_command) {
        const int m = codec_.Find(f);
        if (status_msgs_.empty() ? IsIn(command_msgs_, m)
                                 : command_before && in->has_status && IsIn(status_msgs_, m)) {
          break;
        }
      }
    }
  }

  void SetLockstep(bool on) override { lockstep_ = on; }
  bool CarriesStatus() const override { return !status_msgs_.empty(); }
  bool CarriesHeartbeat() const override { return !heartbeat_msgs_.empty() || canopen_ != nullptr; }
  // On the harness's own relay: the socket nodes that joined (the firmware's among them).
  std::int64_t Joined() const override {
    return relay_ != nullptr ? static_cast<std::int64_t>(relay_->stats().nodes_joined) : -1;
  }
  void PeerRestarted() override { codec_.ResetCounters(); }
  bool RefuseSdo(int index, int subindex, std::uint32_t abort_code) override {
    if (canopen_ == nullptr) return false;
    refuse_index_ = index;
    refuse_subindex_ = subindex;
    refuse_code_ = abort_code;
    return true;
  }

  // The CANopen drive's heartbeat: every producer period in operational state (counted in
  // published steps: plant time in lockstep).
  void PublishDriveHeartbeat(const SensorOutput& out, std::int64_t now) {
    if (drive_state_ != co::kStateOperational || out.drive_heartbeat_loss) {
      steps_since_drive_hb_ = drive_hb_steps_;  // the next one goes out at once
      return;
    }
    if (++steps_since_drive_hb_ < drive_hb_steps_) return;
    steps_since_drive_hb_ = 0;
    SendDriveHeartbeat(co::kStateOperational, now);
  }

  void SendDriveHeartbeat(std::uint8_t state, std::int64_t now) {
    can_frame f{};
    f.can_id = co::HeartbeatId(canopen_->node_id);
    f.len = 1;
    f.data[0] = state;
    SendFrame(f, now);
  }

  // The simulated driver's DriverStatus: every kStatusPeriodSteps published steps, and at once
  // when the fault bits change (so a fault reaches the firmware in the step it appears).
  void PublishDriverStatus(const SensorOutput& out, std::int64_t now) {
    const std::uint32_t faults = out.fault_line || out.driver_fault ? pc::kFaultOvercurrent : 0U;
    // A CANopen drive sends PDOs in operational state only.
    if (canopen_ != nullptr && drive_state_ != co::kStateOperational) return;
    if (driver_msgs_.empty() ||
        (status_sent_ && faults == status_faults_ && ++steps_since_status_ < status_steps_)) {
      return;
    }
    const double volts = std::isfinite(command_volts_) ? command_volts_ : 0.0;
    double amps = command_drives_ ? std::max(volts, 0.0) / kCoilOhms : 0.0;
    if (current_in_ma_) amps *= 1000.0;
    for (const int m : driver_msgs_) {
      can_frame f{};
      codec_.Begin(m, &f);
      bool ok = true;
      const auto set = [&](CanIn role, double v) { ok = SetRole(role, v, m, &f) && ok; };
      set(CanIn::kDriverCurrent, amps);
      set(CanIn::kDriverFaults, faults);
      if (!ok) continue;
      codec_.Seal(m, &f);
      SendFrame(f, now);
    }
    status_sent_ = true;
    status_faults_ = faults;
    steps_since_status_ = 0;
  }

  void Close() override {
    if (relay_ != nullptr) {
      relay_open_ = false;
      rx_count_ = 0;
      return;
    }
    iface_.Close();
    if (relay_thread_.joinable()) {
      relay_stop_.store(true);
      relay_thread_.join();
    }
    own_relay_.Close();
  }

  PortCounters counters() const override { return {published_, received_, rejected_}; }

 private:
  // The role's signal into frame f of message m when the profile maps it there; false when the
  // value does not fit the signal (true when the role is elsewhere or unmapped).
  bool SetRole(CanIn role, double v, int m, can_frame* f) {
    const pf::SignalRef r = profile_->inputs[static_cast<std::size_t>(role)];
    return r.message != m || codec_.Set(f, r, v) == protocol::SignalError::kNone;
  }

  bool IsOpen() const { return relay_ != nullptr ? relay_open_ : iface_.is_open(); }

  canbus::CanResult SendFrame(const can_frame& f, std::int64_t now) {
    if (relay_ != nullptr) {
      relay_->Broadcast(&f);
      return canbus::CanResult::kOk;
    }
    return iface_.Send(f, now + kTxDeadlineNs, now);
  }

  canbus::CanResult ReceiveFrame(can_frame* f, std::int64_t* stamp) {
    if (relay_ == nullptr) return iface_.Receive(f, stamp);
    if (rx_count_ == 0) return canbus::CanResult::kEmpty;
    *f = rx_[rx_head_].frame;
    *stamp = rx_[rx_head_].stamp;
    rx_head_ = (rx_head_ + 1) % rx_.size();
    --rx_count_;
    return canbus::CanResult::kOk;
  }

  void Reconnect(std::int64_t now) {
    if (relay_ != nullptr) return;
    if (relay_thread_.joinable() || !canbus::IsLocalBusPath(endpoint_) || now < next_reconnect_) {
      return;
    }
    next_reconnect_ = now + kReconnectNs;
    const int fd = canbus::OpenLocalBusNode(endpoint_.c_str(), nullptr);
    if (fd >= 0) {
      iface_.Attach(fd);
      codec_.ResetCounters();
    }
  }

  static bool IsIn(const std::vector<int>& v, int m) {
    return std::find(v.begin(), v.end(), m) != v.end();
  }

  // The firmware's messages the port listens to: filters, and which is which.
  void Index() {
    const pf::CanProfile& p = *profile_;
    const auto add = [](std::vector<int>* v, int m) {
      if (m >= 0 && !IsIn(*v, m)) v->push_back(m);
    };
    for (const CanOut r :
         {CanOut::kCommand, CanOut::kEnable, CanOut::kEnableValid, CanOut::kSafe, CanOut::kEcho}) {
      add(&command_msgs_, p.outputs[static_cast<std::size_t>(r)].message);
    }
    add(&heartbeat_msgs_, p.outputs[static_cast<std::size_t>(CanOut::kHeartbeatSafe)].message);
    for (const CanOut r : {CanOut::kStatusSafe, CanOut::kStatusCauses, CanOut::kStatusOverruns,
                           CanOut::kStatusSafeEntries}) {
      add(&status_msgs_, p.outputs[static_cast<std::size_t>(r)].message);
    }
    const int grant = p.inputs[static_cast<std::size_t>(CanIn::kGrant)].message;
    for (const CanIn r :
         {CanIn::kVelocity, CanIn::kDisplacement, CanIn::kDemand, CanIn::kBodyVelocity,
          CanIn::kForce, CanIn::kFaultLine, CanIn::kSensorSeq}) {
      const int m = p.inputs[static_cast<std::size_t>(r)].message;
      if (m != grant) add(&sensor_msgs_, m);
    }
    for (const CanIn r : {CanIn::kBodyAcceleration, CanIn::kWheelVelocity}) {
      const int m = p.inputs[static_cast<std::size_t>(r)].message;
      if (m >= 0 && m != grant && !IsIn(sensor_msgs_, m)) add(&chassis_msgs_, m);
      if (m != grant) add(&sensor_msgs_, m);
    }
    for (const CanIn r :
         {CanIn::kFloorAcceleration1, CanIn::kFloorAcceleration2, CanIn::kFloorAcceleration3}) {
      const int m = p.inputs[static_cast<std::size_t>(r)].message;
      if (m >= 0 && m != grant && !IsIn(sensor_msgs_, m)) add(&structure_msgs_, m);
      if (m != grant) add(&sensor_msgs_, m);
    }
    for (const CanIn r : {CanIn::kDriverFaults, CanIn::kDriverCurrent}) {
      const int m = p.inputs[static_cast<std::size_t>(r)].message;
      if (!IsIn(sensor_msgs_, m) && m != grant) add(&driver_msgs_, m);
    }
    for (const auto* list : {&command_msgs_, &heartbeat_msgs_, &status_msgs_}) {
      for (const int m : *list) {
        const pf::DbcMessage& msg = p.dbc.messages[static_cast<std::size_t>(m)];
        filters_.push_back({pf::WireId(msg), (msg.extended ? CAN_EFF_MASK : CAN_SFF_MASK) |
                                                 CAN_EFF_FLAG | CAN_RTR_FLAG});
      }
    }
    // The driver status goes out at its message's period (the DBC's GenMsgCycleTime or the
    // profile's period_ms; the shortest of several), in published 1 ms steps.
    std::int64_t status_ns = 0;
    for (const int m : driver_msgs_) {
      const std::int64_t t = p.specs[static_cast<std::size_t>(m)].period_ns;
      if (t > 0 && (status_ns == 0 || t < status_ns)) status_ns = t;
    }
    if (status_ns > 0) {
      status_steps_ = static_cast<std::uint32_t>(std::max<std::int64_t>(1, status_ns / 1'000'000));
    }
    const pf::SignalRef current = p.inputs[static_cast<std::size_t>(CanIn::kDriverCurrent)];
    current_in_ma_ = current.mapped() && p.dbc.messages[static_cast<std::size_t>(current.message)]
                                                 .signals[static_cast<std::size_t>(current.signal)]
                                                 .unit == "mA";
    if (p.canopen) {
      canopen_ = &*p.canopen;
      drive_state_ = co::kStatePreOperational;  // booted before the firmware came
      for (const std::uint32_t id : {co::kNmtId, co::kSyncId, co::SdoRequestId(canopen_->node_id),
                                     co::HeartbeatId(canopen_->own_node_id)}) {
        filters_.push_back({id, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
      }
    }
    last_.resize(p.dbc.messages.size());
  }

  // The firmware's CANopen frames to the drive: NMT, SDO requests, its heartbeat, SYNC. true:
  // one of them (handled).
  bool HandleCanopen(const can_frame& f, std::int64_t stamp, DriverInput* in) {
    if ((f.can_id & CAN_EFF_FLAG) != 0) return false;
    const std::uint32_t id = f.can_id & CAN_SFF_MASK;
    const int node = canopen_->node_id;
    const std::int64_t now = common::MonotonicNs();
    if (id == co::kNmtId) {
      if (f.len < 2 || (f.data[1] != node && f.data[1] != 0)) return true;  // another node's
      ++received_;
      switch (f.data[0]) {
        case co::kNmtStart:
          drive_state_ = co::kStateOperational;
          break;
        case co::kNmtStop:
          drive_state_ = co::kStateStopped;
          break;
        case co::kNmtPreOperational:
          drive_state_ = co::kStatePreOperational;
          break;
        case co::kNmtResetNode:
        case co::kNmtResetCommunication:
          SendDriveHeartbeat(co::kStateBootUp, now);  // boot-up, then pre-operational
          drive_state_ = co::kStatePreOperational;
          break;
        default:
          ++rejected_;
          break;
      }
      return true;
    }
    if (id == co::SdoRequestId(node)) {
      ++received_;
      ++sdo_requests_;
      can_frame r{};
      r.can_id = co::SdoResponseId(node);
      r.len = 8;
      std::uint16_t index = 0;
      std::uint8_t sub = 0;
      int size = 0;
      std::uint32_t raw = 0;
      if (!co::DecodeSdoDownloadRequest(f.data, f.len, &index, &sub, &size, &raw)) {
        // Only expedited downloads are played: command specifier not valid.
        co::EncodeSdoAbort(static_cast<std::uint16_t>(f.data[1] | f.data[2] << 8), f.data[3],
                           0x05040001, r.data);
      } else if (static_cast<int>(index) == refuse_index_ &&
                 (refuse_subindex_ < 0 || refuse_subindex_ == sub)) {
        co::EncodeSdoAbort(index, sub, refuse_code_, r.data);
      } else {
        if (index == 0x1017 && sub == 0 && raw > 0) drive_hb_steps_ = raw;  // producer time [ms]
        co::EncodeSdoDownloadAck(index, sub, r.data);
      }
      SendFrame(r, now);
      return true;
    }
    if (id == co::HeartbeatId(canopen_->own_node_id)) {
      ++received_;
      if (f.len >= 1 && (f.data[0] & 0x7FU) == co::kStateOperational) {
        in->heartbeat_ns = stamp;
        ++in->heartbeats;
      }
      return true;
    }
    if (id == co::kSyncId) {
      ++received_;
      return true;
    }
    return false;
  }

  // The IDs the harness listens to (filters_), for the relay's tap: what the sockets' receive
  // filters do on SocketCAN, so frames of other IDs (a babbling node's) never fill its queue.
  bool Wanted(const can_frame& f) const {
    for (const can_filter& k : filters_) {
      if ((f.can_id & k.can_mask) == (k.can_id & k.can_mask)) return true;
    }
    return false;
  }

  void Handle(const can_frame& f, std::int64_t stamp, DriverInput* in) {
    if (canopen_ != nullptr && HandleCanopen(f, stamp, in)) return;
    const int m = codec_.Find(f);
    const bool command = IsIn(command_msgs_, m), heartbeat = IsIn(heartbeat_msgs_, m),
               status = IsIn(status_msgs_, m);
    if (m < 0) {
      ++rejected_;
      return;
    }
    if (!command && !heartbeat && !status) return;  // the device side's own messages
    if (codec_.Check(m, f) != pc::Reject::kNone) {
      ++rejected_;
      return;
    }
    const pf::CanProfile& p = *profile_;
    const auto get = [&](CanOut role, double* v) {
      const pf::SignalRef r = p.outputs[static_cast<std::size_t>(role)];
      return r.message == m && codec_.Get(f, r, v) == protocol::SignalError::kNone;
    };
    ++received_;
    double v = 0.0;
    if (command) {
      if (get(CanOut::kCommand, &v)) {
        v = p.command.Invert(v);  // the driver's set-point back to the coil's E [V]
        in->has_command = true;
        in->volts = v;
        in->command_ns = stamp;
        command_volts_ = v;
      }
      if (get(CanOut::kEcho, &v)) {
        const pf::SignalRef r = p.outputs[static_cast<std::size_t>(CanOut::kEcho)];
        in->has_echo = true;
        in->echo = ExpandEcho(static_cast<std::uint32_t>(v), last_published_, p.Layout(r).length);
      }
      if (get(CanOut::kSafe, &v)) {
        in->has_safe = true;
        in->safe = v != 0.0;
      }
      double valid = 1.0;
      const bool has_valid = get(CanOut::kEnableValid, &valid);
      if (get(CanOut::kEnable, &v) && (!has_valid || valid != 0.0)) {
        in->has_enable = true;
        in->enable = v != 0.0;
      }
      command_drives_ = !in->has_enable || in->enable;
    }
    if (heartbeat) {
      in->heartbeat_ns = stamp;
      ++in->heartbeats;
    }
    if (status) {
      in->has_status = true;
      if (get(CanOut::kStatusCauses, &v)) in->status_causes = static_cast<std::uint16_t>(v);
      if (get(CanOut::kStatusSafe, &v)) in->status_safe = v != 0.0;
    }
  }

  std::string endpoint_;
  canbus::LocalBusRelay* relay_ = nullptr;  // in-process node of this relay (else a socket)
  std::shared_ptr<TapFanOut> fan_;          // the relay's tap shared with other ports
  bool relay_open_ = false;
  bool lockstep_ = false;
  struct Rx {
    can_frame frame;
    std::int64_t stamp;
  };
  std::array<Rx, 256> rx_{};
  std::size_t rx_head_ = 0, rx_count_ = 0;
  canbus::LocalBusRelay own_relay_;
  std::thread relay_thread_;
  std::atomic<bool> relay_stop_{false};
  canbus::CanIface iface_;
  std::shared_ptr<const pf::CanProfile> profile_;
  pf::FrameCodec codec_;
  std::vector<can_filter> filters_;
  // Profile messages by kind: the firmware's (heard) and the plant's and driver's (sent).
  std::vector<int> command_msgs_, heartbeat_msgs_, status_msgs_, sensor_msgs_, driver_msgs_;
  std::vector<int> chassis_msgs_;    // sensor messages carrying only chassis roles
  std::vector<int> structure_msgs_;  // sensor messages carrying only floor accelerations
  // The simulated driver: the latest command heard, the DriverStatus schedule.
  double command_volts_ = 0.0;
  bool command_drives_ = false;
  bool status_sent_ = false;
  std::uint32_t status_faults_ = 0;
  std::uint32_t steps_since_status_ = 0;
  std::uint32_t status_steps_ = kStatusPeriodSteps;  // the driver status period [1 ms steps]
  bool current_in_ma_ = false;  // the driver_current signal's unit is mA (else A)
  // The CANopen drive ([canopen]; nullptr without): NMT state, heartbeat schedule [steps],
  // the SDO refusal test hook (index -1: none).
  const pf::CanopenConfig* canopen_ = nullptr;
  std::uint8_t drive_state_ = co::kStatePreOperational;
  std::uint32_t drive_hb_steps_ = kDriveHeartbeatSteps, steps_since_drive_hb_ = 0;
  int refuse_index_ = -1, refuse_subindex_ = -1;
  std::uint32_t refuse_code_ = 0;
  std::uint64_t sdo_requests_ = 0;
  std::vector<can_frame> last_;  // per message: the latest sensor frame sent (stall)
  bool have_last_ = false;
  std::uint32_t last_published_ = 0;
  std::int64_t next_reconnect_ = 0;
  std::uint64_t published_ = 0, received_ = 0, rejected_ = 0;
};

void TapFanOut::Tap(void* context, const void* frame, std::int64_t stamp_ns) {
  for (CanPort* p : static_cast<TapFanOut*>(context)->ports) CanPort::Tap(p, frame, stamp_ns);
}

}  // namespace

std::vector<std::unique_ptr<PlantPort>> MakeCanPortsOnRelay(
    canbus::LocalBusRelay& relay,
    const std::vector<std::shared_ptr<const profile::CanProfile>>& profiles) {
  auto fan = std::make_shared<TapFanOut>();
  std::vector<std::unique_ptr<PlantPort>> ports;
  for (const auto& p : profiles) ports.push_back(std::make_unique<CanPort>(relay, p, fan));
  return ports;
}

void PublishTick(const std::vector<PlantPort*>& ports, const std::vector<SensorOutput>& outs,
                 std::int64_t grant_ns) {
  for (std::size_t i = 0; i < ports.size() && i < outs.size(); ++i) ports[i]->Publish(outs[i]);
  if (!ports.empty()) ports.front()->SendGrant(grant_ns);
}

std::unique_ptr<PlantPort> MakeCanPort(const std::string& endpoint,
                                       std::shared_ptr<const profile::CanProfile> profile) {
  return std::make_unique<CanPort>(endpoint, std::move(profile));
}

std::unique_ptr<PlantPort> MakeCanPortOnRelay(canbus::LocalBusRelay& relay,
                                              std::shared_ptr<const profile::CanProfile> profile) {
  return std::make_unique<CanPort>(relay, std::move(profile));
}

}  // namespace mrd::hil
