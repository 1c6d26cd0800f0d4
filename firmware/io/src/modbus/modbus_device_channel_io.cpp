// ModbusChannels (modbus_channels.hpp): each channel's write (its profile's write requests, as
// the one-channel device's WriteProfileOnce), the start-up and periodic writes of every
// channel, and the channel views the loop holds. Nothing here allocates after construction.
#include <unistd.h>

#include <cmath>
#include <cstdint>

#include "modbus_channels_parts.hpp"
#include "modbus_link.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/modbus/modbus_channels.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/protocol/modbus_frame.hpp"

namespace mrd::firmware {
namespace {

namespace pf = mrd::profile;
namespace mb = mrd::protocol::modbus;

constexpr int kReadAttempts = 4;                           // seqlock attempts per Read
constexpr std::int64_t kLockstepIdleNs = 20'000;           // the hand-over wait's poll
constexpr std::int64_t kLockstepHandOverNs = 100'000'000;  // the worker writing a tick
bool Retriable(IoError e) { return e == IoError::kTimeout || e == IoError::kCrc; }

double WrapCounter(const pf::ModbusPoint& pt, std::uint64_t n) {
  switch (pt.type) {
    case pf::ModbusType::kInt16:
      return static_cast<double>(n & 0x7FFFU);
    case pf::ModbusType::kUint16:
      return static_cast<double>(n & 0xFFFFU);
    case pf::ModbusType::kInt32:
      return static_cast<double>(n & 0x7FFFFFFFU);
    case pf::ModbusType::kUint32:
      return static_cast<double>(n & 0xFFFFFFFFU);
    case pf::ModbusType::kFloat32:
      return static_cast<double>(n & 0xFFFFFFU);
    case pf::ModbusType::kBit:
      return static_cast<double>(n & 1U);
  }
  return 0.0;
}

double CounterValue(const pf::ModbusPoint& pt, std::uint64_t n) {
  return WrapCounter(pt, n) * pt.scale + pt.offset;
}

void Signal(int fd) {
  if (fd < 0) return;
  const std::uint64_t one = 1;
  (void)!write(fd, &one, sizeof one);
}

}  // namespace

BusDevice& ModbusChannels::channel(std::size_t k) { return *views_[k]; }

ModbusChannels::Outcome ModbusChannels::WriteChannel(std::size_t k, const Command& c, IoError* why,
                                                     bool interruptible) {
  Channel& ch = ch_[k];
  const pf::ModbusProfile& p = *ch.profile;
  const std::uint32_t mask = 1U << k;
  ch.written_tick = c.tick;  // sent or failed, a command is not sent again
  ch.any_written = true;
  const auto routed = [&](Output o) { return (config_.outputs & Bit(o)) != 0; };
  const bool reset = interruptible && p.Out(pf::ModbusOut::kFaultReset).mapped &&
                     ch.reset_rule.Edge(ch.driver_fault_seen,
                                        ch.causes_known.load(std::memory_order_relaxed)
                                            ? ch.status_causes.load(std::memory_order_relaxed)
                                            : ~0U,
                                        common::MonotonicNs(),
                                        static_cast<std::int64_t>(p.fault_reset_ms) * 1'000'000);
  double v[pf::kNumModbusOut] = {};
  const auto fill = [&](double setpoint, bool enable, bool safe) {
    const auto set = [&](pf::ModbusOut r, double x) { v[static_cast<std::size_t>(r)] = x; };
    set(pf::ModbusOut::kCommand, routed(Output::kCommand) ? setpoint : ch.safe_setpoint);
    set(pf::ModbusOut::kEnable, routed(Output::kEnable) && enable && !safe ? 1.0 : 0.0);
    set(pf::ModbusOut::kSafe, safe ? 1.0 : 0.0);
    set(pf::ModbusOut::kEcho, CounterValue(p.Out(pf::ModbusOut::kEcho), c.echo));
    set(pf::ModbusOut::kHeartbeat,
        routed(Output::kHeartbeat) ? CounterValue(p.Out(pf::ModbusOut::kHeartbeat), c.tick) : 0.0);
    const bool status = routed(Output::kStatus);
    set(pf::ModbusOut::kStatusSafe, status && safe ? 1.0 : 0.0);
    set(pf::ModbusOut::kStatusCauses,
        status ? static_cast<double>(ch.status_causes.load(std::memory_order_relaxed)) : 0.0);
    set(pf::ModbusOut::kStatusOverruns, 0.0);
    set(pf::ModbusOut::kStatusSafeEntries, 0.0);
    const auto live = [&](pf::ModbusOut role, const std::atomic<double>& a) {
      const double x = status ? a.load(std::memory_order_relaxed) : 0.0;
      std::uint16_t scratch[2];
      pf::ModbusPoint at = p.Out(role);
      at.index = 0;
      set(role, !at.mapped || pf::PutModbusPoint(p, at, x, scratch) ? x : 0.0);
    };
    live(pf::ModbusOut::kStatusModelForce, ch.status_model_force);
    live(pf::ModbusOut::kStatusDemand, ch.status_demand);
    live(pf::ModbusOut::kStatusCommand, ch.status_command);
    set(pf::ModbusOut::kFaultReset, reset ? 1.0 : 0.0);
  };
  const auto encodable = [&]() {
    std::uint16_t scratch[2];
    for (std::size_t i = 0; i < pf::kNumModbusOut; ++i) {
      pf::ModbusPoint at = p.outputs[i];
      at.index = 0;
      if (at.mapped && !pf::PutModbusPoint(p, at, v[i], scratch)) return false;
    }
    return true;
  };
  fill(c.setpoint, c.enable, c.safe);
  bool bad = false;
  if (!encodable()) {
    bad = true;
    fill(ch.safe_setpoint, false, true);
    if (!encodable()) {
      *why = IoError::kBadValue;
      Failed(*why, false, mask);
      return Outcome::kFailed;
    }
  }
  bool safe = c.safe || bad;
  IoError failed = IoError::kNone;
  for (std::size_t q = 0; q < p.writes.size(); ++q) {
    const pf::ModbusRequest& req = p.writes[q];
    for (int i = 0; i < req.count; ++i) words_[static_cast<std::size_t>(i)] = 0;
    for (std::size_t i = 0; i < pf::kNumModbusOut; ++i) {
      const pf::ModbusPoint& pt = p.outputs[i];
      if (pt.mapped && pt.request == static_cast<int>(q)) {
        (void)pf::PutModbusPoint(p, pt, v[i], words_.get());
      }
    }
    std::uint8_t pdu[mb::kMaxPdu], reply[mb::kMaxPdu];
    const int len = pf::PutModbusWrite(req, words_.get(), pdu);
    link_->set_unit(req.unit);
    int reply_len = 0;
    writing_safe_ = safe;
    IoError e = IoError::kNone;
    const ModbusLink::Result r =
        link_->Transact(pdu, len, reply, &reply_len, &e, interruptible ? wake_ : -1, waker_.get());
    writing_safe_ = false;
    if (r == ModbusLink::Result::kAbandoned) {
      if (!link_->broken()) ch.written_safe = safe;
      return Outcome::kAbandoned;
    }
    if (r == ModbusLink::Result::kOk) {
      std::uint8_t exception = 0;
      const pf::ModbusReply check = pf::CheckModbusWrite(req, pdu, reply, reply_len, &exception);
      if (check == pf::ModbusReply::kOk) {
        GoodExchange();
        continue;
      }
      e = check == pf::ModbusReply::kException ? IoError::kException : IoError::kRejectedFrame;
    }
    Failed(e, false, mask);
    if (failed == IoError::kNone) failed = e;
    if (e == IoError::kDisconnected || link_->broken()) {
      *why = failed;
      return Outcome::kFailed;
    }
    ch.written_safe = safe;
    if (!safe) {
      fill(ch.safe_setpoint, false, true);
      safe = true;
    }
    if (resync_) {
      resync_ = false;
      if (!link_->Quiet(interruptible ? wake_ : -1, waker_.get())) return Outcome::kAbandoned;
    }
  }
  ch.written_safe = safe;
  if (failed != IoError::kNone) {
    *why = failed;
    return Outcome::kFailed;
  }
  if (bad) {
    *why = IoError::kBadValue;
    Failed(*why, false, mask);
    return Outcome::kFailed;
  }
  ch.counters.tx_ok.fetch_add(1, std::memory_order_relaxed);
  return Outcome::kOk;
}

bool ModbusChannels::WriteFixed(const pf::ModbusFixedWrite& w, std::uint32_t mask, IoError* why,
                                std::uint8_t* exception) {
  if (resync_) {
    resync_ = false;
    if (!link_->Quiet(-1, waker_.get())) {
      *why = IoError::kDisconnected;
      return false;
    }
  }
  const pf::ModbusRequest req = w.request();
  const std::uint16_t word = w.value;
  std::uint8_t pdu[mb::kMaxPdu], reply[mb::kMaxPdu];
  const int len = pf::PutModbusWrite(req, &word, pdu);
  link_->set_unit(req.unit);
  int reply_len = 0;
  IoError e = IoError::kNone;
  const ModbusLink::Result r = link_->Transact(pdu, len, reply, &reply_len, &e, -1, waker_.get());
  if (r == ModbusLink::Result::kOk) {
    const pf::ModbusReply check = pf::CheckModbusWrite(req, pdu, reply, reply_len, exception);
    if (check == pf::ModbusReply::kOk) {
      GoodExchange();
      return true;
    }
    e = check == pf::ModbusReply::kException ? IoError::kException : IoError::kRejectedFrame;
  } else if (e == IoError::kNone) {
    e = IoError::kDisconnected;
  }
  Failed(e, e == IoError::kException || e == IoError::kRejectedFrame, mask);
  *why = e;
  return false;
}

bool ModbusChannels::StartUpWrites(Sample* s) {
  for (std::size_t i = 0; i < startup_.size(); ++i) {
    IoError why = IoError::kNone;
    std::uint8_t exception = 0;
    bool ok = false;
    for (int attempt = 0; attempt <= config_.retries && !ok; ++attempt) {
      ok = WriteFixed(*startup_[i], startup_mask_[i], &why, &exception);
      if (!ok && (!Retriable(why) || link_->broken())) break;
    }
    if (ok) continue;
    if (why == IoError::kException || why == IoError::kRejectedFrame) {
      startup_exception_.store(exception);
      startup_refused_.store(static_cast<int>(i) + 1);
    }
    for (std::size_t k = 0; k < n_; ++k) {
      if ((startup_mask_[i] & (1U << k)) != 0) {
        ch_[k].counters.tx_failed.fetch_add(1, std::memory_order_relaxed);
      }
    }
    FailAll(s, all_, config_.inputs != 0 || config_.lockstep, true, why);
    return false;
  }
  return true;
}

void ModbusChannels::PeriodicWrites(Sample* s) {
  for (std::size_t i = 0; i < periodic_.size(); ++i) {
    const pf::ModbusFixedWrite& w = *periodic_[i];
    const std::int64_t now = common::MonotonicNs();
    if (now < periodic_due_[i]) continue;
    periodic_due_[i] = now + static_cast<std::int64_t>(w.period_ms) * 1'000'000;
    IoError why = IoError::kNone;
    std::uint8_t exception = 0;
    if (WriteFixed(w, periodic_mask_[i], &why, &exception)) continue;
    for (std::size_t k = 0; k < n_; ++k) {
      if ((periodic_mask_[i] & (1U << k)) != 0) {
        ch_[k].counters.tx_failed.fetch_add(1, std::memory_order_relaxed);
      }
    }
    FailAll(s, periodic_mask_[i], false, true, why);
    if (link_->broken()) return;
  }
}

IoStatus ModbusChannels::Read(std::size_t k, SensorFrame* frame, IoError* why) {
  Channel& ch = ch_[k];
  // The worker may be publishing right now: then the previous copy.
  Sample s;
  bool got = false;
  for (int i = 0; i < kReadAttempts && !got; ++i) got = sample_.TryRead(&s);
  if (got) ch.cached = s.ch[k];
  const ChannelSample& c = ch.cached;
  ch.last_write_failed = c.write_failed;
  ch.last_why = c.why;
  IoStatus status = IoStatus::kNoData;
  if (c.accepted != ch.seen_accepted) {
    ch.seen_accepted = c.accepted;
    ch.last_seq = c.seq;
    status = IoStatus::kOk;
  }
  if (c.accepted > 0) {
    MergeRouted(config_.inputs, frame, [&c](Input i) {
      return Stamped{c.values[static_cast<std::size_t>(i)], c.stamp_ns};
    });
    if ((config_.inputs & Bit(Input::kFaultLine)) != 0) {
      frame->fault_line = frame->fault_line || c.fault_line;
    }
    frame->fault_line = frame->fault_line || c.driver_fault;
  }
  if (c.read_failed) {
    *why = c.why;
    return IoStatus::kFault;
  }
  return status;
}

IoStatus ModbusChannels::Write(std::size_t k, const IoTime& t, const DriverCommand& cmd,
                               IoError* why) {
  Channel& ch = ch_[k];
  // Lockstep: the published tick's commands go out before a later one replaces this channel's
  // one-slot mailbox (as the one-channel device's hand-over; simulated time only).
  const std::uint64_t released = released_tick_.load(std::memory_order_relaxed);  // own write
  if (config_.lockstep && released != 0) {
    const std::int64_t until = t.wall_ns + kLockstepHandOverNs;
    while (running_.load(std::memory_order_relaxed) &&
           !(handled_any_.load(std::memory_order_acquire) &&
             handled_tick_.load(std::memory_order_acquire) >= released - 1) &&
           common::MonotonicNs() < until) {
      (void)common::SleepUntilNs(common::MonotonicNs() + kLockstepIdleNs);
    }
  }
  Command c;
  c.tick = cmd.tick;
  c.enable = cmd.enable;
  c.safe = cmd.safe;
  c.echo = ch.last_seq;
  if (cmd.safe) ch.command_map.Reset();  // the safe state is not rate-limited
  c.setpoint = ch.command_map.Apply(cmd.volts, static_cast<double>(config_.period_ns) * 1e-9);
  if (!std::isfinite(cmd.volts)) c.setpoint = cmd.volts;  // refused by the worker: safe
  ch.command.Write(c);
  if (c.safe && !ch.posted_safe && !config_.lockstep) Signal(wake_);
  ch.posted_safe = c.safe;
  Sample s;
  if (sample_.TryRead(&s)) {
    ch.last_write_failed = s.ch[k].write_failed;
    ch.last_why = s.ch[k].why;
  }
  if (ch.last_write_failed) {
    *why = ch.last_why;
    return IoStatus::kFault;
  }
  return IoStatus::kOk;
}

void ModbusChannels::PublishStatus(std::size_t k, const TelemetrySnapshot& stats) {
  Channel& ch = ch_[k];
  ch.status_causes.store(static_cast<std::uint16_t>(stats.active_causes & 0xFFFFU),
                         std::memory_order_relaxed);
  ch.causes_known.store(true, std::memory_order_relaxed);
  ch.status_model_force.store(stats.model_force_n, std::memory_order_relaxed);
  ch.status_demand.store(stats.force_demand_n, std::memory_order_relaxed);
  ch.status_command.store(stats.last_command_v, std::memory_order_relaxed);
  if (!config_.lockstep) return;
  // Lockstep: a tick goes out once every channel posted its command and status of it.
  if (ch.command.version() != 0) ch.published = ch.command.Read().tick + 1;
  std::uint64_t released = ch_[0].published;
  for (std::size_t i = 1; i < n_; ++i) {
    released = ch_[i].published < released ? ch_[i].published : released;
  }
  if (released > released_tick_.load(std::memory_order_relaxed)) {
    released_tick_.store(released, std::memory_order_release);
    Signal(wake_);
  }
}

DeviceCounters ModbusChannels::counters(std::size_t k) const {
  const Counters& s = ch_[k].counters;
  DeviceCounters c;
  c.rx_ok = s.rx_ok.load(std::memory_order_relaxed);
  c.rx_rejected = s.rx_rejected.load(std::memory_order_relaxed);
  c.tx_ok = s.tx_ok.load(std::memory_order_relaxed);
  c.tx_failed = s.tx_failed.load(std::memory_order_relaxed);
  c.reconnects = s.reconnects.load(std::memory_order_relaxed);
  for (std::size_t i = 0; i < kNumIoErrors; ++i) {
    c.errors[i] = s.errors[i].load(std::memory_order_relaxed);
  }
  c.last_error = static_cast<IoError>(s.last_error.load(std::memory_order_relaxed));
  return c;
}

}  // namespace mrd::firmware
