#include "mrd/firmware/io/can/can_device.hpp"

#include <linux/can.h>
#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <ctime>
#include <limits>
#include <memory>

#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/devices.hpp"
#include "mrd/firmware/io/input_roles.hpp"
#include "mrd/firmware/telemetry.hpp"

namespace mrd::firmware {
namespace {

namespace pc = protocol::can;

constexpr std::uint16_t Saturate16(std::uint64_t v) {
  return v > 0xFFFFU ? std::uint16_t{0xFFFF} : static_cast<std::uint16_t>(v);
}

IoError ErrorOf(pc::Reject r) {
  switch (r) {
    case pc::Reject::kBadChecksum:
      return IoError::kCrc;
    case pc::Reject::kOutOfRange:
    case pc::Reject::kNonFinite:
      return IoError::kBadValue;
    default:
      return IoError::kRejectedFrame;
  }
}

namespace pf = profile;

// A role's signal reference in the profile.
pf::SignalRef In(const pf::CanProfile& p, pf::CanIn r) {
  return p.inputs[static_cast<std::size_t>(r)];
}
pf::SignalRef Out(const pf::CanProfile& p, pf::CanOut r) {
  return p.outputs[static_cast<std::size_t>(r)];
}

// The echo signal's raw range (a sensor seq wider than the echo field wraps into it).
std::uint32_t EchoMask(const pf::CanProfile& p) {
  const pf::SignalRef r = Out(p, pf::CanOut::kEcho);
  if (!r.mapped()) return 0;
  const int len = p.Layout(r).length;
  return len >= 32 ? 0xFFFFFFFFU : static_cast<std::uint32_t>((std::uint64_t{1} << len) - 1U);
}

std::shared_ptr<const pf::CanProfile> ProfileOf(const CanConfig& config) {
  if (config.can_profile != nullptr) return config.can_profile;
  // The built-in profile lives as long as the program: no ownership to share.
  return std::shared_ptr<const pf::CanProfile>(&pf::NativeCanProfile(),
                                               [](const pf::CanProfile*) {});
}

}  // namespace

CanDevice::CanDevice(const CanConfig& config)
    : config_(config),
      profile_(ProfileOf(config)),
      codec_(*profile_),
      command_(profile_->command),
      reopenable_(true) {
  Index();
  Publish();
}

CanDevice::CanDevice(const CanConfig& config, int fd)
    : config_(config),
      profile_(ProfileOf(config)),
      codec_(*profile_),
      command_(profile_->command),
      reopenable_(false) {
  Index();
  iface_.Attach(fd);
  Publish();
}

void CanDevice::Index() {
  const pf::CanProfile& p = *profile_;
  for (std::size_t r = 0; r < pf::kNumCanIn; ++r) {
    const pf::SignalRef ref = p.inputs[r];
    if (!ref.mapped()) continue;
    rx_roles_[static_cast<std::size_t>(ref.message)] =
        static_cast<std::uint16_t>(rx_roles_[static_cast<std::size_t>(ref.message)] | (1U << r));
  }
  const auto add = [](std::vector<int>* v, int m) {
    if (m >= 0 && std::find(v->begin(), v->end(), m) == v->end()) v->push_back(m);
  };
  for (const pf::CanOut r : {pf::CanOut::kCommand, pf::CanOut::kEnable, pf::CanOut::kEnableValid,
                             pf::CanOut::kSafe, pf::CanOut::kEcho}) {
    add(&command_msgs_, Out(p, r).message);
  }
  add(&heartbeat_msgs_, Out(p, pf::CanOut::kHeartbeatSafe).message);
  for (const pf::CanOut r :
       {pf::CanOut::kStatusSafe, pf::CanOut::kStatusCauses, pf::CanOut::kStatusOverruns,
        pf::CanOut::kStatusSafeEntries, pf::CanOut::kStatusModelForce, pf::CanOut::kStatusDemand,
        pf::CanOut::kStatusCommand}) {
    add(&status_msgs_, Out(p, r).message);
  }
  status_driver_msg_ = In(p, pf::CanIn::kDriverFaults).message;
  // Receive filters: every message carrying an input role (exact id and frame format).
  for (std::size_t m = 0; m < p.dbc.messages.size(); ++m) {
    if (rx_roles_[m] == 0) continue;
    const pf::DbcMessage& msg = p.dbc.messages[m];
    filters_.push_back({pf::WireId(msg), (msg.extended ? CAN_EFF_MASK : CAN_SFF_MASK) |
                                             CAN_EFF_FLAG | CAN_RTR_FLAG});
  }
  IndexCanopen();
}

int CanDevice::Open(std::string* error) const {
  if (!config_.local_bus.empty()) return canbus::OpenLocalBusNode(config_.local_bus.c_str(), error);
  return canbus::OpenSocketCan(config_.interface.c_str(), filters_.data(), filters_.size(), error);
}

bool CanDevice::Configure(std::string* error) {
  if (iface_.is_open()) return true;
  if (!reopenable_) {
    *error = "can: no file descriptor";
    return false;
  }
  const int fd = Open(error);
  if (fd < 0) return false;
  iface_.Attach(fd);
  return true;
}

std::int64_t CanDevice::Now(std::int64_t wall_ns) const {
  return config_.lockstep ? granted_ns_ : wall_ns;
}

bool CanDevice::Activate(std::string* error) {
  if (canopen_ != nullptr && !StartCanopen(error)) return false;
  const std::int64_t now = Now(common::MonotonicNs());
  next_heartbeat_ns_ = now;
  next_status_ns_ = now;
  next_reconnect_ns_ = now;
  driver_status_ns_ = now;
  drive_heartbeat_ns_ = now;  // the drive's heartbeat is watched from here
  next_own_heartbeat_ns_ = now;
  next_sync_ns_ = now;
  active_ = true;
  // A drive that booted during the start-up missed it: configure and start it again.
  if (canopen_ != nullptr && drive_state_ == 0x00) ReconfigureNext(common::MonotonicNs());
  return true;
}

void CanDevice::Deactivate() {
  if (iface_.is_open()) {
    // Last word on the bus: 0 V, enable low, safe. Not from a device that never started
    // (a refused CANopen start-up): it never drove, and a command would read as a sign of life.
    const std::int64_t now = common::MonotonicNs();
    const bool last_word =
        active_ && (config_.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) != 0;
    if (last_word) (void)SendCommand(DriverCommand{0.0, false, true, 0}, now, false);
    // After what a period's Write held (lockstep: a period that ended without its status).
    if (last_word || iface_.held()) (void)iface_.Release(now);
    iface_.Close();
  }
  active_ = false;
  Publish();
}

void CanDevice::Count(IoError error) {
  ++counters_.errors[static_cast<std::size_t>(error)];
  counters_.last_error = error;
}

void CanDevice::Reject(pc::Reject reason) {
  ++counters_.rx_rejected;
  ++rejects_since_read_;
  Count(ErrorOf(reason));
}

void CanDevice::TryReconnect(std::int64_t now) {
  if (!reopenable_ || now < next_reconnect_ns_) return;
  next_reconnect_ns_ = now + kReconnectInterval;
  const int fd = Open(nullptr);
  if (fd < 0) return;
  iface_.Attach(fd);
  codec_.ResetCounters();
  ++counters_.reconnects;
}

void CanDevice::Grant(double time_us) {
  const auto t = static_cast<std::int64_t>(std::llround(time_us * 1000.0));
  if (t > granted_ns_) granted_ns_ = t;  // grants never move time backwards
  // The values that came before this grant are its step's samples.
  for (std::size_t r = 0; r < pf::kNumCanIn; ++r) {
    if ((unstamped_ >> r) & 1U) values_[r].stamp_ns = granted_ns_;
  }
  unstamped_ = 0;
  if (drive_heartbeat_unstamped_) drive_heartbeat_ns_ = granted_ns_;  // CANopen: as the samples
  drive_heartbeat_unstamped_ = false;
  got_grant_ = true;
}

bool CanDevice::Handle(const can_frame& f, std::int64_t stamp, std::int64_t wall_ns) {
  if (canopen_ != nullptr && HandleCanopen(f, wall_ns)) return false;
  const int m = codec_.Find(f);
  if (m < 0) {
    if (canopen_ != nullptr && IsCanopenManagement(f)) return false;  // another node's
    Reject(pc::Reject::kUnknownId);
    return false;
  }
  const std::uint16_t roles = rx_roles_[static_cast<std::size_t>(m)];
  if (roles == 0) return false;  // ours from another node, or a message without a role
  pc::Reject r = codec_.Check(m, f);
  // Every role the frame carries must decode within its range, or none is taken.
  std::array<double, pf::kNumCanIn> v{};
  for (std::size_t i = 0; i < pf::kNumCanIn && r == pc::Reject::kNone; ++i) {
    if (((roles >> i) & 1U) == 0) continue;
    if (codec_.Get(f, profile_->inputs[i], &v[i]) != protocol::SignalError::kNone) {
      r = pc::Reject::kOutOfRange;
    }
  }
  if (r != pc::Reject::kNone) {
    Reject(r);
    return false;
  }
  ++counters_.rx_ok;
  const auto has = [roles](pf::CanIn role) {
    return ((roles >> static_cast<unsigned>(role)) & 1U) != 0;
  };
  if (config_.lockstep) stamp = granted_ns_;
  bool fresh = false;
  for (const InputRole& ir : kInputRoles) {
    // The sampled signals (every input but the fault line).
    const auto i = static_cast<std::size_t>(ir.role);
    if (((roles >> i) & 1U) == 0 || ir.input == Input::kFaultLine) continue;
    values_[i] = {v[i], stamp};
    if (config_.lockstep) unstamped_ = static_cast<std::uint16_t>(unstamped_ | (1U << i));
    fresh = fresh || (config_.inputs & Bit(ir.input)) != 0;
  }
  if (has(pf::CanIn::kFaultLine)) {
    fault_input_ = v[static_cast<std::size_t>(pf::CanIn::kFaultLine)] != 0.0;
    fresh = fresh || (config_.inputs & Bit(Input::kFaultLine)) != 0;
  }
  if (has(pf::CanIn::kSensorSeq)) {
    last_seq_ = static_cast<std::uint32_t>(v[static_cast<std::size_t>(pf::CanIn::kSensorSeq)]);
  }
  if (has(pf::CanIn::kDriverFaults)) {
    driver_faults_ =
        static_cast<std::uint32_t>(v[static_cast<std::size_t>(pf::CanIn::kDriverFaults)]);
    driver_status_ns_ = Now(wall_ns);
  }
  if (has(pf::CanIn::kDriverCurrent)) {
    driver_current_ = v[static_cast<std::size_t>(pf::CanIn::kDriverCurrent)];
  }
  if (has(pf::CanIn::kGrant) && config_.lockstep)
    Grant(v[static_cast<std::size_t>(pf::CanIn::kGrant)]);
  return fresh;
}

IoStatus CanDevice::Read(const IoTime& t, SensorFrame* frame, IoError* why) {
  // Wall time of the period (deadlines, reconnects); Now(now): granted time in lockstep, which
  // a grant drained below may move on (the next step's), so not t.loop_ns.
  const std::int64_t now = t.wall_ns;
  if (!iface_.is_open()) TryReconnect(now);
  IoError fault = IoError::kNone;
  bool fresh = fresh_in_wait_;
  fresh_in_wait_ = false;
  bool flooded = false;
  if (!iface_.is_open()) {
    fault = IoError::kDisconnected;
  } else {
    iface_.Flush(now);
    in_period_ = config_.lockstep;
    // A follower in lockstep: the frames up to the grant of this tick, as they come; the
    // drain below then reads nothing (that grant ends it).
    if (follower() && !FollowGrant(t.loop_ns, &fresh) && fault == IoError::kNone &&
        rejects_since_read_ <= kMaxRejectsPerRead) {
      fault = iface_.is_open() ? IoError::kTimeout : IoError::kDisconnected;
      Count(fault);
    }
    // Drains to the newest frame (each keeps its arrival stamp). In lockstep a grant ends the
    // drain: what follows it belongs to the next step (the grant stays pending for the next
    // WaitGrant). A flood ends it too: the period is a fault whatever the rest holds.
    int k = 0;
    std::int64_t first_stamp = 0, last_stamp = 0;  // arrivals of the frames drained
    for (; k < kMaxFramesPerRead && iface_.is_open() && !got_grant_; ++k) {
      if (rejects_since_read_ > kMaxRejectsPerRead) break;
      can_frame f{};
      std::int64_t stamp = 0;
      const canbus::CanResult r = iface_.Receive(&f, &stamp);
      if (r == canbus::CanResult::kEmpty) break;
      if (r == canbus::CanResult::kOk) {
        if (k == 0) first_stamp = stamp;
        last_stamp = stamp;
        fresh = Handle(f, stamp, now) || fresh;
      } else if (r == canbus::CanResult::kBadFrame) {
        Reject(pc::Reject::kWrongDlc);
      } else if (r == canbus::CanResult::kDisconnected) {
        fault = IoError::kDisconnected;
        Count(fault);
        next_reconnect_ns_ = now + kReconnectInterval;
      } else if (r == canbus::CanResult::kBusOff) {
        fault = IoError::kBusOff;
        Count(fault);
      } else {
        Count(IoError::kSystem);
      }
    }
    // More refused frames than a healthy bus has: a babbling node, whose fault holds for
    // kFloodHoldNs after its last flooded period (a babbler that pauses for a few periods does
    // not make the bus healthy). Or a budget of frames that arrived within kFloodSpanNs with
    // more still waiting: a flood of well-formed frames. A backlog a stall of this process left
    // (frames spread over the stall) is no bus fault: its samples are merely old (stale).
    const bool babble = rejects_since_read_ > kMaxRejectsPerRead;
    flooded = babble || (k == kMaxFramesPerRead && !config_.lockstep &&
                         last_stamp - first_stamp < kFloodSpanNs && iface_.Readable());
    if (babble) flood_until_ns_ = Now(now) + kFloodHoldNs;
  }
  rejects_since_read_ = 0;
  if (flooded) Count(IoError::kOverflow);
  if ((flooded || Now(now) < flood_until_ns_) && fault == IoError::kNone)
    fault = IoError::kOverflow;
  MergeRouted(config_.inputs, frame, [this](Input i) { return values_[RoleIndex(i)]; });
  if ((config_.inputs & Bit(Input::kFaultLine)) != 0 && fault_input_) frame->fault_line = true;
  // A fault the current driver reports (any fault bit), or a driver status that stopped coming
  // (its message's timeout), is the driver's fault line, as the Modbus sensor block's
  // driver-fault bit is: the watchdog's fault_line cause.
  if (driver_faults_ != 0) frame->fault_line = true;
  if (status_driver_msg_ >= 0 && active_) {
    const std::int64_t timeout =
        profile_->specs[static_cast<std::size_t>(status_driver_msg_)].timeout_ns;
    if (timeout > 0 && Now(now) - driver_status_ns_ > timeout) frame->fault_line = true;
  }
  // A CANopen drive whose heartbeat stopped or says other than operational.
  if (canopen_ != nullptr && active_ && DriveFault(now)) frame->fault_line = true;
  Publish();
  if (fault != IoError::kNone) {
    *why = fault;
    return IoStatus::kFault;
  }
  return fresh ? IoStatus::kOk : IoStatus::kNoData;
}

bool CanDevice::MotionTooOld(std::int64_t now) const {
  constexpr std::uint32_t kMotion = Bit(Input::kVelocity) | Bit(Input::kDisplacement);
  if (config_.lockstep || (config_.inputs & kMotion) == 0) return false;
  // Never sampled: the watchdog already holds the safe state (stale), no driving command.
  const std::int64_t stamp = values_[RoleIndex(Input::kVelocity)].stamp_ns;
  return stamp != std::numeric_limits<std::int64_t>::min() && stamp < now - config_.max_age_ns;
}

bool CanDevice::Send(const can_frame& f, std::int64_t now) {
  return Sent(iface_.Send(f, now + config_.tx_deadline_ns, now));
}

bool CanDevice::Sent(canbus::CanResult r) {
  counters_.tx_ok = iface_.stats().tx_frames;
  IoError e = IoError::kNone;
  switch (r) {
    case canbus::CanResult::kOk:
      return true;
    case canbus::CanResult::kTimedOut:
      e = IoError::kTimeout;
      break;
    case canbus::CanResult::kOverflow:
      e = IoError::kOverflow;
      break;
    case canbus::CanResult::kDisconnected:
      e = IoError::kDisconnected;
      break;
    default:
      e = IoError::kSystem;
      break;
  }
  ++counters_.tx_failed;
  Count(e);
  return false;
}

IoStatus CanDevice::Write(const IoTime& io, const DriverCommand& cmd, IoError* why) {
  const std::int64_t now = io.wall_ns;
  if (!iface_.is_open()) {
    ++counters_.tx_failed;
    Publish();
    *why = IoError::kDisconnected;
    return IoStatus::kFault;
  }
  // Lockstep: the period's frames (command, heartbeat, status) leave together at the end of
  // PublishStatus, so the harness, which waits for all of them, wakes once per period. They
  // keep the period's wall time as `now`: a stop between here and there expires none.
  if (in_period_) iface_.Hold();
  bool ok = true;
  const std::uint32_t out = config_.outputs;
  if ((out & (Bit(Output::kCommand) | Bit(Output::kEnable))) != 0) {
    if (!cmd.safe && MotionTooOld(now)) {
      // The tick was held up (preempted, stopped) after the watchdog saw fresh data: driving
      // the coil now would act on an old sample. Not sent (timeout); the loop commands the
      // safe state instead.
      ++counters_.tx_failed;
      Count(IoError::kTimeout);
      Publish();
      *why = IoError::kTimeout;
      return IoStatus::kFault;
    }
    // fault_reset: an edge while the driver reports a (latched) fault and the firmware has no
    // other cause, at most once per fault_reset_ms of device time (granted time in lockstep).
    const bool reset =
        Out(*profile_, pf::CanOut::kFaultReset).mapped() &&
        reset_rule_.Edge(driver_faults_ != 0, active_causes_, Now(now), config_.fault_reset_ns);
    ok = SendCommand(cmd, now, reset);
  }
  const std::int64_t t = Now(now);  // schedules run in granted time in lockstep
  if ((out & Bit(Output::kHeartbeat)) != 0 && t >= next_heartbeat_ns_) {
    next_heartbeat_ns_ += config_.heartbeat_period_ns;
    if (next_heartbeat_ns_ <= t) next_heartbeat_ns_ = t + config_.heartbeat_period_ns;
    for (const int m : heartbeat_msgs_) {
      can_frame f{};
      codec_.Begin(m, &f);
      (void)codec_.Set(&f, Out(*profile_, pf::CanOut::kHeartbeatSafe), cmd.safe ? 1.0 : 0.0);
      codec_.Seal(m, &f);
      ok = Send(f, now) && ok;
    }
  }
  if (canopen_ != nullptr) ok = ProduceCanopen(now, t) && ok;
  Publish();
  if (!ok) {
    *why = counters_.last_error;
    return IoStatus::kFault;
  }
  return IoStatus::kOk;
}

void CanDevice::PublishStatus(const IoTime& io, const TelemetrySnapshot& stats) {
  active_causes_ = stats.active_causes;  // the next Write's fault_reset rule
  SendStatus(io, stats);
  in_period_ = false;
  if (iface_.held()) {
    // The period's frames held since Write (lockstep), in one write.
    (void)Sent(iface_.Release(io.wall_ns));
    Publish();
  }
}

void CanDevice::SendStatus(const IoTime& io, const TelemetrySnapshot& stats) {
  if ((config_.outputs & Bit(Output::kStatus)) == 0 || !iface_.is_open()) return;
  const std::int64_t now = io.wall_ns;
  const std::int64_t t = Now(now);
  if (t < next_status_ns_) return;
  next_status_ns_ += config_.status_period_ns;
  if (next_status_ns_ <= t) next_status_ns_ = t + config_.status_period_ns;
  for (const int m : status_msgs_) {
    can_frame f{};
    codec_.Begin(m, &f);
    const auto set = [&](pf::CanOut role, double v) {
      const pf::SignalRef r = Out(*profile_, role);
      if (r.message == m) (void)codec_.Set(&f, r, v);
    };
    set(pf::CanOut::kStatusSafe, stats.safe ? 1.0 : 0.0);
    set(pf::CanOut::kStatusCauses, static_cast<double>(stats.active_causes & 0xFFFFU));
    set(pf::CanOut::kStatusOverruns, Saturate16(stats.overruns));
    set(pf::CanOut::kStatusSafeEntries, Saturate16(stats.watchdog.entries));
    // Live telemetry (a value beyond its signal's range is not sent: the signal stays 0).
    set(pf::CanOut::kStatusModelForce, stats.model_force_n);
    set(pf::CanOut::kStatusDemand, stats.force_demand_n);
    set(pf::CanOut::kStatusCommand, stats.last_command_v);
    codec_.Seal(m, &f);
    Send(f, now);
  }
  Publish();
}

bool CanDevice::SendCommand(const DriverCommand& cmd, std::int64_t now, bool reset) {
  const pf::CanProfile& p = *profile_;
  const bool enable_routed = (config_.outputs & Bit(Output::kEnable)) != 0;
  // The profile's way from E to the driver's set-point; the safe state is not slew-limited.
  if (cmd.safe) command_.Reset();
  const double setpoint = command_.Apply(cmd.volts, static_cast<double>(config_.period_ns) * 1e-9);
  bool ok = true;
  for (const int m : command_msgs_) {
    can_frame f{};
    const auto fill = [&](double sp, bool enable, bool safe, bool pulse) {
      codec_.Begin(m, &f);
      bool fits = true;
      const auto set = [&](pf::CanOut role, double v) {
        const pf::SignalRef r = Out(p, role);
        if (r.message == m && codec_.Set(&f, r, v) != protocol::SignalError::kNone) fits = false;
      };
      set(pf::CanOut::kCommand, sp);
      set(pf::CanOut::kEnable, enable_routed && enable ? 1.0 : 0.0);
      set(pf::CanOut::kEnableValid, enable_routed ? 1.0 : 0.0);
      set(pf::CanOut::kSafe, safe ? 1.0 : 0.0);
      set(pf::CanOut::kEcho, static_cast<double>(last_seq_ & EchoMask(p)));
      set(pf::CanOut::kFaultReset, pulse ? 1.0 : 0.0);
      return fits;
    };
    if (!std::isfinite(cmd.volts) || !fill(setpoint, cmd.enable, cmd.safe, reset)) {
      // Not representable (never from the loop: the configuration proves its range): the
      // safe state instead (the set-point of 0 V, which the configuration proves is the
      // driver's off), and the write reported as failed.
      Count(IoError::kBadValue);
      ok = false;
      (void)fill(p.command.SafeSetpoint(0.0), false, true, false);
    }
    codec_.Seal(m, &f);
    ok = Send(f, now) && ok;
  }
  return ok;
}

bool CanDevice::FollowGrant(std::int64_t loop_ns, bool* fresh) {
  got_grant_ = false;  // the previous tick's grant (it ended that tick's drain)
  if (granted_ns_ >= loop_ns) {
    got_grant_ = true;  // this tick's grant is in already: what follows is the next step's
    return true;
  }
  const std::int64_t until = common::MonotonicNs() + config_.follower_wait_ns;
  while (iface_.is_open() && rejects_since_read_ <= kMaxRejectsPerRead) {
    can_frame f{};
    std::int64_t stamp = 0;
    const std::int64_t now = common::MonotonicNs();
    const canbus::CanResult r = iface_.Receive(&f, &stamp);
    if (r == canbus::CanResult::kOk) {
      *fresh = Handle(f, stamp, now) || *fresh;
      if (!got_grant_) continue;
      if (granted_ns_ >= loop_ns) return true;  // this tick's: its samples are all in
      got_grant_ = false;                       // an earlier step's: read on
      continue;
    }
    if (r == canbus::CanResult::kBadFrame) {
      Reject(pc::Reject::kWrongDlc);
      continue;
    }
    if (r == canbus::CanResult::kDisconnected) {
      next_reconnect_ns_ = common::MonotonicNs() + kReconnectInterval;
      return false;
    }
    // The socket is empty: the deadline is checked only now, so a process stopped (SIGSTOP)
    // past it still reads what came meanwhile before it gives up.
    if (now >= until) return false;
    if (config_.stop != nullptr && config_.stop->load(std::memory_order_relaxed)) return false;
    // In slices, so a stop request ends the wait promptly (as the grant clock's).
    const std::int64_t wait_ns = std::min(until - now, GrantClock::kSliceNs);
    const timespec ts{static_cast<time_t>(wait_ns / 1'000'000'000),
                      static_cast<long>(wait_ns % 1'000'000'000)};
    pollfd p{iface_.fd(), POLLIN, 0};
    (void)ppoll(&p, 1, &ts, nullptr);
  }
  return false;
}

bool CanDevice::WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) {
  const std::int64_t until = common::MonotonicNs() + timeout_ns;
  // Nothing read ahead: wait on the socket before reading it (the harness sends a period's
  // frames after the previous period's command, so a read now would find none: one system
  // call saved per period).
  bool wait_first = !got_grant_ && iface_.is_open() && iface_.buffered() == 0;
  while (true) {
    if (got_grant_) {
      got_grant_ = false;
      *t_ns = granted_ns_;
      Publish();
      return true;
    }
    const std::int64_t now = common::MonotonicNs();
    if (!iface_.is_open()) TryReconnect(now);
    const bool skipped_read = wait_first;
    bool drained = wait_first;
    wait_first = false;
    if (iface_.is_open() && !drained) {
      can_frame f{};
      std::int64_t stamp = 0;
      const canbus::CanResult r = iface_.Receive(&f, &stamp);
      if (r == canbus::CanResult::kOk) {
        fresh_in_wait_ = Handle(f, stamp, now) || fresh_in_wait_;
        continue;
      }
      if (r == canbus::CanResult::kBadFrame) {
        Reject(pc::Reject::kWrongDlc);
        continue;
      }
      if (r == canbus::CanResult::kDisconnected) {
        Count(IoError::kDisconnected);
        next_reconnect_ns_ = now + kReconnectInterval;
      }
      drained = r == canbus::CanResult::kEmpty;
    }
    if (now >= until && !skipped_read) break;
    // Nothing waiting: sleep on the fd (or, with the bus gone, until the next reconnect try or
    // the deadline).
    std::int64_t wait_ns = until > now ? until - now : 0;
    if (!drained && wait_ns > kReconnectInterval / 10) wait_ns = kReconnectInterval / 10;
    const timespec ts{static_cast<time_t>(wait_ns / 1'000'000'000),
                      static_cast<long>(wait_ns % 1'000'000'000)};
    if (drained) {
      pollfd p{iface_.fd(), POLLIN, 0};
      (void)ppoll(&p, 1, &ts, nullptr);
    } else {
      (void)nanosleep(&ts, nullptr);
    }
  }
  Publish();  // no grant in this slice: the clock keeps waiting (grant_clock.hpp)
  return false;
}

std::unique_ptr<BusDevice> MakeCanDevice(const CanConfig& config) {
  return std::make_unique<CanDevice>(config);
}

}  // namespace mrd::firmware
