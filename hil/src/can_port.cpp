// The harness's CAN side (plant_port.hpp): the plant's sensors send SensorMotion and
// SensorForce every step; the simulated driver hears DriverCommand and Heartbeat and sends
// DriverStatus every kStatusPeriodSteps steps and at once when its fault bits change: the
// current of the latest command (its set-point over a kCoilOhms coil while it enables the
// coil, else 0 A) and the driver's fault (the step's fault_line: the scenario's fault_line
// fault, `mrd-hil serve --fault-line`) as the overcurrent bit (docs/mrd.dbc). Commands are
// timed by their bus stamps (when the firmware sent them). Endpoint: a local frame bus socket
// path (contains '/') or a SocketCAN interface. On a local bus path nobody serves yet (no socket, or one left by a dead relay),
// the port runs the relay itself on a thread: the harness then owns the bus, and the firmware
// loses it when the harness exits (the peer-restart test relies on that).
#include <linux/can.h>
#include <poll.h>

#include <ctime>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <thread>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/hil/plant_port.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace mrd::hil {
namespace {

namespace pc = protocol::can;

constexpr int kMaxFramesPerPoll = 64;
constexpr std::int64_t kTxDeadlineNs = 1'000'000;  // one plant period
constexpr std::int64_t kReconnectNs = 100'000'000;
constexpr std::uint32_t kStatusPeriodSteps = 100;  // DriverStatus period: 100 ms (docs/mrd.dbc)
constexpr double kCoilOhms = 5.0;  // simulated coil (e.g. a Lord RD-1005-3: about 5 ohm)

constexpr can_filter kFilters[] = {
    {pc::kDriverCommandId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
    {pc::kHeartbeatId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
    {pc::kFirmwareStatusId, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG},
};

// The IDs the harness listens to (kFilters), for the relay's tap: what the sockets' receive
// filters do on SocketCAN, so frames of other IDs (a babbling node's) never fill its queue.
bool Wanted(const can_frame& f) {
  for (const can_filter& k : kFilters) {
    if ((f.can_id & k.can_mask) == (k.can_id & k.can_mask)) return true;
  }
  return false;
}

// The 32-bit step number a 16-bit echo stands for: the latest one published with those low
// bits (the echo never runs ahead of what was published).
std::uint32_t ExpandEcho(std::uint16_t echo, std::uint32_t last_published) {
  std::uint32_t s = (last_published & 0xFFFF0000U) | echo;
  if (s > last_published && s >= 0x10000U) s -= 0x10000U;
  return s;
}

class CanPort final : public PlantPort {
 public:
  explicit CanPort(std::string endpoint) : endpoint_(std::move(endpoint)) {}
  // An in-process node of a relay this process runs (the harness owns the bus).
  explicit CanPort(canbus::LocalBusRelay& relay) : relay_(&relay) {
    relay.SetTap(&CanPort::Tap, this);
  }
  ~CanPort() override {
    if (relay_ != nullptr) relay_->SetTap(nullptr, nullptr);
    Close();
  }

  const char* name() const override { return "can"; }

  bool Open(std::string* error) override {
    if (relay_ != nullptr) {
      relay_open_ = true;
      return true;
    }
    if (!canbus::IsLocalBusPath(endpoint_)) {
      const int fd = canbus::OpenSocketCan(endpoint_.c_str(), kFilters, std::size(kFilters), error);
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
    last_published_ = out.seq;
    const std::int64_t now = canbus::MonotonicNs();
    if (!IsOpen()) Reconnect(now);
    if (!IsOpen()) return;
    PublishDriverStatus(out, now);  // the driver's node: not subject to the sensors' faults
    if (out.fault == SensorFault::kDrop) return;
    if (out.fault == SensorFault::kStall) {
      // The same frames again: counters repeat, the firmware refuses them.
      if (have_last_) {
        SendFrame(last_motion_, now);
        SendFrame(last_force_, now);
      }
      return;
    }
    can_frame motion{}, force{};
    const double v = out.fault == SensorFault::kOutOfRange || out.fault == SensorFault::kNan
                         ? 0.0
                         : out.sample.v;
    const bool motion_ok =
        pc::Encode(pc::SensorMotion{v, out.sample.x,
                                    static_cast<std::uint16_t>(out.seq & 0xFFFFU), motion_counter_},
                   &motion) == pc::Reject::kNone;
    const bool force_ok = pc::Encode(pc::SensorForce{out.sample.demand, out.sample.body_velocity,
                                                     out.sample.force, force_counter_},
                                     &force) == pc::Reject::kNone;
    if (motion_ok) {
      if (out.fault == SensorFault::kOutOfRange || out.fault == SensorFault::kNan) {
        // A raw velocity outside the DBC's [-300, 300] cm/s (0x7FFF = 327.67; 0x8000, the
        // most negative code, stands for "not a number"), sealed with a valid checksum.
        const std::uint16_t raw = out.fault == SensorFault::kNan ? 0x8000U : 0x7FFFU;
        motion.data[0] = static_cast<std::uint8_t>(raw & 0xFFU);
        motion.data[1] = static_cast<std::uint8_t>(raw >> 8);
        motion.data[motion.len - 1] = pc::Checksum(motion);
      } else if (out.fault == SensorFault::kCorrupt) {
        motion.data[1] ^= 0x10U;  // after sealing: checksum mismatch
      }
      motion_counter_ = static_cast<std::uint8_t>((motion_counter_ + 1) & 0x0F);
      if (SendFrame(motion, now) == canbus::CanResult::kOk) ++published_;
    }
    if (force_ok) {
      if (out.fault == SensorFault::kCorrupt) force.data[3] ^= 0x01U;
      force_counter_ = static_cast<std::uint8_t>((force_counter_ + 1) & 0x0F);
      SendFrame(force, now);
    }
    if (motion_ok && force_ok) {
      last_motion_ = motion;
      last_force_ = force;
      have_last_ = true;
    }
  }

  bool SendGrant(std::int64_t t_ns) override {
    const std::int64_t now = canbus::MonotonicNs();
    if (!IsOpen()) Reconnect(now);
    if (!IsOpen()) return false;
    can_frame f{};
    if (pc::Encode(pc::TimeGrant{static_cast<std::uint64_t>(t_ns / 1000), grant_counter_}, &f) !=
        pc::Reject::kNone) {
      return false;
    }
    grant_counter_ = static_cast<std::uint8_t>((grant_counter_ + 1) & 0x0F);
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
      // Lockstep: a tick's messages end with its status; what follows belongs to the next
      // tick (or the firmware's shutdown) and waits for the next Poll.
      if (lockstep_ && command_before && in->has_status &&
          pc::Classify(f) == pc::Message::kFirmwareStatus) {
        break;
      }
    }
  }

  void SetLockstep(bool on) override { lockstep_ = on; }
  void PeerRestarted() override {
    command_check_.Reset();
    heartbeat_check_.Reset();
  }

  // The simulated driver's DriverStatus: every kStatusPeriodSteps published steps, and at once
  // when the fault bits change (so a fault reaches the firmware in the step it appears).
  void PublishDriverStatus(const SensorOutput& out, std::int64_t now) {
    const std::uint8_t faults = out.fault_line ? pc::kFaultOvercurrent : std::uint8_t{0};
    if (status_sent_ && faults == status_faults_ && ++steps_since_status_ < kStatusPeriodSteps) {
      return;
    }
    const double volts = std::isfinite(command_volts_) ? command_volts_ : 0.0;
    const double amps = command_drives_ ? std::clamp(volts, 0.0, pc::kMaxVoltage) / kCoilOhms : 0.0;
    can_frame f{};
    if (pc::Encode(pc::DriverStatus{amps, faults, status_counter_}, &f) != pc::Reject::kNone) return;
    status_counter_ = static_cast<std::uint8_t>((status_counter_ + 1) & 0x0F);
    SendFrame(f, now);
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

  // Frames the relay's socket nodes sent, with their bus stamps (called from
  // LocalBusRelay::Step).
  static void Tap(void* context, const void* frame, std::int64_t stamp_ns) {
    auto* self = static_cast<CanPort*>(context);
    if (!self->relay_open_) return;
    can_frame f;
    std::memcpy(&f, frame, sizeof f);
    if (!Wanted(f)) return;
    if (self->rx_count_ == self->rx_.size()) {
      ++self->rejected_;  // overflow: as a full controller FIFO
      return;
    }
    const std::size_t slot = (self->rx_head_ + self->rx_count_) % self->rx_.size();
    self->rx_[slot].frame = f;
    self->rx_[slot].stamp = stamp_ns;
    ++self->rx_count_;
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
      command_check_.Reset();
      heartbeat_check_.Reset();
    }
  }

  void Handle(const can_frame& f, std::int64_t stamp, DriverInput* in) {
    switch (pc::Classify(f)) {
      case pc::Message::kDriverCommand: {
        pc::DriverCommand m;
        pc::Reject r = pc::Decode(f, &m);
        if (r == pc::Reject::kNone) r = command_check_.Check(m.counter);
        if (r != pc::Reject::kNone) {
          ++rejected_;
          return;
        }
        ++received_;
        in->has_command = true;
        in->volts = m.volts;
        in->command_ns = stamp;
        in->has_echo = true;
        in->echo = ExpandEcho(m.echo_seq, last_published_);
        in->has_safe = true;
        in->safe = m.safe;
        if (m.enable_valid) {
          in->has_enable = true;
          in->enable = m.enable;
        }
        command_volts_ = m.volts;
        command_drives_ = !m.enable_valid || m.enable;
        return;
      }
      case pc::Message::kHeartbeat: {
        pc::Heartbeat m;
        pc::Reject r = pc::Decode(f, &m);
        if (r == pc::Reject::kNone) r = heartbeat_check_.Check(m.counter);
        if (r != pc::Reject::kNone) {
          ++rejected_;
          return;
        }
        ++received_;
        in->heartbeat_ns = stamp;
        ++in->heartbeats;
        return;
      }
      case pc::Message::kFirmwareStatus: {
        pc::FirmwareStatus m;
        if (pc::Decode(f, &m) != pc::Reject::kNone) {
          ++rejected_;
          return;
        }
        ++received_;
        in->has_status = true;
        in->status_causes = m.active_causes;
        in->status_safe = m.safe;
        return;
      }
      case pc::Message::kSensorMotion:
      case pc::Message::kSensorForce:
      case pc::Message::kTimeGrant:
      case pc::Message::kDriverStatus:
        return;  // the device side's own IDs from another node
      case pc::Message::kUnknown:
        ++rejected_;
        return;
    }
  }

  std::string endpoint_;
  canbus::LocalBusRelay* relay_ = nullptr;  // in-process node of this relay (else a socket)
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
  pc::CounterCheck command_check_, heartbeat_check_;
  std::uint8_t motion_counter_ = 0, force_counter_ = 0, grant_counter_ = 0, status_counter_ = 0;
  // The simulated driver: the latest command heard, the DriverStatus schedule.
  double command_volts_ = 0.0;
  bool command_drives_ = false;
  bool status_sent_ = false;
  std::uint8_t status_faults_ = 0;
  std::uint32_t steps_since_status_ = 0;
  can_frame last_motion_{}, last_force_{};
  bool have_last_ = false;
  std::uint32_t last_published_ = 0;
  std::int64_t next_reconnect_ = 0;
  std::uint64_t published_ = 0, received_ = 0, rejected_ = 0;
};

}  // namespace

std::unique_ptr<PlantPort> MakeCanPort(const std::string& endpoint) {
  return std::make_unique<CanPort>(endpoint);
}

std::unique_ptr<PlantPort> MakeCanPortOnRelay(canbus::LocalBusRelay& relay) {
  return std::make_unique<CanPort>(relay);
}

}  // namespace mrd::hil
