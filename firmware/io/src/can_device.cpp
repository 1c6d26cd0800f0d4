#include "mrd/firmware/io/can_device.hpp"

#include <linux/can.h>
#include <poll.h>

#include <cerrno>
#include <ctime>
#include <limits>
#include <memory>

#include "mrd/canbus/socket.hpp"
#include "mrd/firmware/io/devices.hpp"
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

// The IDs the firmware listens to (SocketCAN receive filters; exact standard data frames).
constexpr can_filter kFilters[] = {
    {pc::kSensorMotionId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
    {pc::kSensorForceId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
    {pc::kTimeGrantId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
    {pc::kDriverStatusId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
};

}  // namespace

CanDevice::CanDevice(const CanConfig& config) : config_(config), reopenable_(true) { Publish(); }

CanDevice::CanDevice(const CanConfig& config, int fd) : config_(config), reopenable_(false) {
  iface_.Attach(fd);
  Publish();
}

int CanDevice::Open(std::string* error) const {
  if (!config_.local_bus.empty()) return canbus::OpenLocalBusNode(config_.local_bus.c_str(), error);
  return canbus::OpenSocketCan(config_.interface.c_str(), kFilters, std::size(kFilters), error);
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

std::int64_t CanDevice::Now() const {
  return config_.lockstep ? granted_ns_ : canbus::MonotonicNs();
}

bool CanDevice::Activate(std::string* error) {
  (void)error;
  const std::int64_t now = Now();
  next_heartbeat_ns_ = now;
  next_status_ns_ = now;
  next_reconnect_ns_ = now;
  active_ = true;
  return true;
}

void CanDevice::Deactivate() {
  if (iface_.is_open()) {
    // Last word on the bus: 0 V, enable low, safe.
    can_frame f{};
    const bool enable_routed = (config_.outputs & Bit(Output::kEnable)) != 0;
    if ((config_.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) != 0 &&
        pc::Encode(pc::DriverCommand{0.0, false, enable_routed, true, last_seq_, command_counter_},
                   &f) == pc::Reject::kNone) {
      command_counter_ = static_cast<std::uint8_t>((command_counter_ + 1) & 0x0F);
      const std::int64_t now = canbus::MonotonicNs();
      Send(f, now);
      iface_.Flush(now);
    }
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
  motion_check_.Reset();
  force_check_.Reset();
  status_check_.Reset();
  grant_check_.Reset();
  ++counters_.reconnects;
}

bool CanDevice::HandleGrant(const can_frame& f) {
  pc::TimeGrant m;
  pc::Reject r = pc::Decode(f, &m);
  if (r == pc::Reject::kNone) r = grant_check_.Check(m.counter);
  if (r != pc::Reject::kNone) {
    Reject(r);
    return false;
  }
  ++counters_.rx_ok;
  const auto t = static_cast<std::int64_t>(m.time_us) * 1000;
  if (t > granted_ns_) granted_ns_ = t;  // grants never move time backwards
  // The sensor values that came before this grant are its step's samples.
  if (unstamped_motion_) velocity_.stamp_ns = displacement_.stamp_ns = granted_ns_;
  if (unstamped_force_) {
    demand_.stamp_ns = body_velocity_.stamp_ns = force_.stamp_ns = granted_ns_;
  }
  unstamped_motion_ = unstamped_force_ = false;
  got_grant_ = true;
  return true;
}

bool CanDevice::Handle(const can_frame& f, std::int64_t stamp) {
  const std::uint32_t in = config_.inputs;
  if (config_.lockstep) stamp = granted_ns_;
  switch (pc::Classify(f)) {
    case pc::Message::kTimeGrant:
      if (config_.lockstep) HandleGrant(f);
      return false;
    case pc::Message::kSensorMotion: {
      pc::SensorMotion m;
      pc::Reject r = pc::Decode(f, &m);
      if (r == pc::Reject::kNone) r = motion_check_.Check(m.counter);
      if (r != pc::Reject::kNone) {
        Reject(r);
        return false;
      }
      ++counters_.rx_ok;
      velocity_ = {m.velocity, stamp};
      displacement_ = {m.displacement, stamp};
      last_seq_ = m.seq;
      unstamped_motion_ = config_.lockstep;
      return (in & (Bit(Input::kVelocity) | Bit(Input::kDisplacement))) != 0;
    }
    case pc::Message::kSensorForce: {
      pc::SensorForce m;
      pc::Reject r = pc::Decode(f, &m);
      if (r == pc::Reject::kNone) r = force_check_.Check(m.counter);
      if (r != pc::Reject::kNone) {
        Reject(r);
        return false;
      }
      ++counters_.rx_ok;
      demand_ = {m.demand, stamp};
      body_velocity_ = {m.body_velocity, stamp};
      force_ = {m.force, stamp};
      unstamped_force_ = config_.lockstep;
      return (in & (Bit(Input::kDemand) | Bit(Input::kBodyVelocity) | Bit(Input::kForce))) != 0;
    }
    case pc::Message::kDriverStatus: {
      pc::DriverStatus m;
      pc::Reject r = pc::Decode(f, &m);
      if (r == pc::Reject::kNone) r = status_check_.Check(m.counter);
      if (r != pc::Reject::kNone) {
        Reject(r);
        return false;
      }
      ++counters_.rx_ok;
      driver_faults_ = m.faults;
      driver_current_ = m.current;
      return false;
    }
    case pc::Message::kDriverCommand:
    case pc::Message::kHeartbeat:
    case pc::Message::kFirmwareStatus:
      return false;  // our own IDs from another node: not for us
    case pc::Message::kUnknown:
      break;
  }
  Reject(pc::Reject::kUnknownId);
  return false;
}

IoStatus CanDevice::Read(SensorFrame* frame, IoError* why) {
  const std::int64_t now = canbus::MonotonicNs();
  if (!iface_.is_open()) TryReconnect(now);
  IoError fault = IoError::kNone;
  bool fresh = fresh_in_wait_;
  fresh_in_wait_ = false;
  bool flooded = false;
  if (!iface_.is_open()) {
    fault = IoError::kDisconnected;
  } else {
    iface_.Flush(now);
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
        fresh = Handle(f, stamp) || fresh;
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
    if (babble) flood_until_ns_ = Now() + kFloodHoldNs;
  }
  rejects_since_read_ = 0;
  if (flooded) Count(IoError::kOverflow);
  if ((flooded || Now() < flood_until_ns_) && fault == IoError::kNone) fault = IoError::kOverflow;
  const std::uint32_t in = config_.inputs;
  if ((in & Bit(Input::kVelocity)) != 0) frame->velocity = velocity_;
  if ((in & Bit(Input::kDisplacement)) != 0) frame->displacement = displacement_;
  if ((in & Bit(Input::kDemand)) != 0) frame->demand = demand_;
  if ((in & Bit(Input::kBodyVelocity)) != 0) frame->body_velocity = body_velocity_;
  if ((in & Bit(Input::kForce)) != 0) frame->force = force_;
  // A fault the current driver reports (any DriverStatus fault bit) is the driver's fault line,
  // as the Modbus sensor block's driver-fault bit is: the watchdog's fault_line cause.
  if (driver_faults_ != 0) frame->fault_line = true;
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
  const std::int64_t stamp = velocity_.stamp_ns;
  return stamp != std::numeric_limits<std::int64_t>::min() && stamp < now - config_.max_age_ns;
}

bool CanDevice::Send(const can_frame& f, std::int64_t now) {
  const canbus::CanResult r = iface_.Send(f, now + config_.tx_deadline_ns, now);
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

IoStatus CanDevice::Write(const DriverCommand& cmd, IoError* why) {
  const std::int64_t now = canbus::MonotonicNs();
  if (!iface_.is_open()) {
    ++counters_.tx_failed;
    Publish();
    *why = IoError::kDisconnected;
    return IoStatus::kFault;
  }
  bool ok = true;
  const std::uint32_t out = config_.outputs;
  if ((out & (Bit(Output::kCommand) | Bit(Output::kEnable))) != 0) {
    const bool enable_routed = (out & Bit(Output::kEnable)) != 0;
    can_frame f{};
    pc::DriverCommand m{cmd.volts, cmd.enable, enable_routed,
                        cmd.safe,  last_seq_,  command_counter_};
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
    if (pc::Encode(m, &f) != pc::Reject::kNone) {
      // Not representable (never from the loop: it commands within [0, E_max]): send the
      // safe state instead and report the write as failed.
      Count(IoError::kBadValue);
      ok = false;
      m = {0.0, false, enable_routed, true, last_seq_, command_counter_};
      pc::Encode(m, &f);
    }
    command_counter_ = static_cast<std::uint8_t>((command_counter_ + 1) & 0x0F);
    ok = Send(f, now) && ok;
  }
  const std::int64_t t = Now();  // schedules run in granted time in lockstep
  if ((out & Bit(Output::kHeartbeat)) != 0 && t >= next_heartbeat_ns_) {
    next_heartbeat_ns_ += config_.heartbeat_period_ns;
    if (next_heartbeat_ns_ <= t) next_heartbeat_ns_ = t + config_.heartbeat_period_ns;
    can_frame f{};
    pc::Encode(pc::Heartbeat{cmd.safe, heartbeat_counter_}, &f);
    heartbeat_counter_ = static_cast<std::uint8_t>((heartbeat_counter_ + 1) & 0x0F);
    ok = Send(f, now) && ok;
  }
  Publish();
  if (!ok) {
    *why = counters_.last_error;
    return IoStatus::kFault;
  }
  return IoStatus::kOk;
}

void CanDevice::PublishStatus(const TelemetrySnapshot& stats) {
  if ((config_.outputs & Bit(Output::kStatus)) == 0 || !iface_.is_open()) return;
  const std::int64_t now = canbus::MonotonicNs();
  const std::int64_t t = Now();
  if (t < next_status_ns_) return;
  next_status_ns_ += config_.status_period_ns;
  if (next_status_ns_ <= t) next_status_ns_ = t + config_.status_period_ns;
  can_frame f{};
  pc::Encode(
      pc::FirmwareStatus{stats.safe, static_cast<std::uint16_t>(stats.active_causes & 0xFFFFU),
                         Saturate16(stats.overruns), Saturate16(stats.watchdog.entries),
                         status_sequence_++},
      &f);
  Send(f, now);
  Publish();
}

bool CanDevice::WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) {
  const std::int64_t until = canbus::MonotonicNs() + timeout_ns;
  while (true) {
    if (got_grant_) {
      got_grant_ = false;
      *t_ns = granted_ns_;
      Publish();
      return true;
    }
    const std::int64_t now = canbus::MonotonicNs();
    if (!iface_.is_open()) TryReconnect(now);
    bool drained = false;
    if (iface_.is_open()) {
      can_frame f{};
      std::int64_t stamp = 0;
      const canbus::CanResult r = iface_.Receive(&f, &stamp);
      if (r == canbus::CanResult::kOk) {
        fresh_in_wait_ = Handle(f, stamp) || fresh_in_wait_;
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
    if (now >= until) break;
    // Nothing waiting: sleep on the fd (or, with the bus gone, until the next reconnect try or
    // the deadline).
    std::int64_t wait_ns = until - now;
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
