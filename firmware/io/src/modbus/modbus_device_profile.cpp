// ModbusDevice on a device profile (modbus_device.hpp, "With a device profile"): the
// profile's grouped reads and its writes, on the worker thread, with the same retries,
// wake-ups and counters as the built-in map's two blocks. Nothing here allocates: the request
// and reply buffers are on the stack, the write words were allocated at construction.
#include <cmath>
#include <cstdint>

#include "modbus_link.hpp"
#include "modbus_waker.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/input_roles.hpp"
#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/protocol/modbus_frame.hpp"

namespace mrd::firmware {
namespace {

namespace pf = mrd::profile;
namespace mb = mrd::protocol::modbus;

bool Retriable(IoError e) { return e == IoError::kTimeout || e == IoError::kCrc; }

// A counter (echo, heartbeat) wrapped into what its register holds, so it never overflows.
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
      return static_cast<double>(n & 0xFFFFFFU);  // exact in float
    case pf::ModbusType::kBit:
      return static_cast<double>(n & 1U);
  }
  return 0.0;
}

// The physical value a counter role carries: the raw count through the point's scale.
double CounterValue(const pf::ModbusPoint& pt, std::uint64_t n) {
  return WrapCounter(pt, n) * pt.scale + pt.offset;
}

}  // namespace

ModbusDevice::Outcome ModbusDevice::ReadProfile(Sample* out, bool* new_grant) {
  Sample& s = *out;
  const pf::ModbusProfile& p = *profile_;
  double values[pf::kNumCanIn] = {};
  std::int64_t stamp_ns = 0;
  IoError why = IoError::kNone;
  for (std::size_t q = 0; q < p.reads.size(); ++q) {
    const pf::ModbusRequest& req = p.reads[q];
    std::uint8_t pdu[8], reply[mb::kMaxPdu];
    const int len = pf::PutModbusRead(req, pdu);
    bool ok = false;
    for (int attempt = 0; attempt <= config_.retries; ++attempt) {
      link_->set_unit(req.unit);
      int reply_len = 0;
      std::int64_t sent_stamp_ns = 0;
      const Outcome r = ReadOnce(pdu, len, reply, &reply_len, &why, &sent_stamp_ns);
      if (r == Outcome::kAbandoned) return Outcome::kAbandoned;
      // The sample is no older than the cycle's first request.
      if (q == 0) stamp_ns = sent_stamp_ns;
      if (r == Outcome::kOk) {
        std::uint8_t exception = 0;
        const pf::ModbusReply check = pf::CheckModbusRead(req, reply, reply_len, &exception);
        if (check == pf::ModbusReply::kOk) {
          for (std::size_t i = 0; i < pf::kNumCanIn; ++i) {
            const pf::ModbusPoint& pt = p.inputs[i];
            if (pt.mapped && pt.request == static_cast<int>(q)) {
              values[i] = pf::ModbusPointValue(p, pt, reply);
            }
          }
          ok = true;
          break;
        }
        why = check == pf::ModbusReply::kException ? IoError::kException : IoError::kRejectedFrame;
        Failed(why, true);
      } else {
        Failed(why, why != IoError::kTimeout && why != IoError::kDisconnected);
      }
      if (!Retriable(why) || link_->broken()) break;
    }
    if (!ok) {
      s.read_failed = true;
      s.why = why;
      return Outcome::kFailed;
    }
  }
  GoodExchange();
  unanswered_since_ns_ = 0;
  for (std::size_t i = 0; i < pf::kNumCanIn; ++i) {
    if (p.inputs[i].mapped && !std::isfinite(values[i])) {  // a float32 NaN or infinity
      Failed(IoError::kBadValue, true);
      s.read_failed = true;
      s.why = IoError::kBadValue;
      return Outcome::kFailed;
    }
  }
  const auto value = [&](pf::CanIn r) { return values[static_cast<std::size_t>(r)]; };
  std::int64_t stamp = stamp_ns;
  if (config_.lockstep) {
    // The grant [us] follows its step's sensor values: they are stamped with it.
    const double g = value(pf::CanIn::kGrant);
    const auto grant = g > 0.0 && g < 9e12 ? static_cast<std::int64_t>(std::llround(g * 1e3)) : 0;
    *new_grant = grant > s.grant_ns;
    if (*new_grant) s.grant_ns = grant;
    stamp = s.grant_ns;
    if (BeforeFirstGrant(&s)) return Outcome::kOk;
  }
  s.read_failed = false;
  const bool has_seq = p.In(pf::CanIn::kSensorSeq).mapped;
  const double sv = value(pf::CanIn::kSensorSeq);
  const std::uint32_t seq = !has_seq                         ? s.seq + 1
                            : sv >= 0.0 && sv < 4294967296.0 ? static_cast<std::uint32_t>(sv)
                                                             : 0U;
  // The fault inputs count on every good read (a frozen sensor seq must not hide them); the
  // driver's faults whether or not [modbus] inputs routes fault_line (as on CAN).
  s.fault_line = value(pf::CanIn::kFaultLine) != 0.0;
  s.driver_fault = value(pf::CanIn::kDriverFaults) != 0.0;
  driver_fault_seen_ = s.driver_fault;
  if (!have_seq_ || seq != s.seq) {  // a repeated seq is not new data
    have_seq_ = true;
    s.seq = seq;
    s.stamp_ns = stamp;
    for (const InputRole& m : kInputRoles) {  // the sampled signals (the fault line above)
      if (m.input != Input::kFaultLine) s.value(m.input) = value(m.role);
    }
    ++s.accepted;
    rx_ok_.fetch_add(1, std::memory_order_relaxed);
  }
  return Outcome::kOk;
}

ModbusDevice::Outcome ModbusDevice::WriteProfileOnce(const Command& c, IoError* why,
                                                     bool interruptible) {
  const pf::ModbusProfile& p = *profile_;
  written_tick_ = c.tick;  // sent or failed, a command is not sent again
  any_written_ = true;
  const auto routed = [&](Output o) { return (config_.outputs & Bit(o)) != 0; };
  // The fault reset (worker only, never at shutdown): an edge when the driver still reports a
  // (latched) fault and the firmware has no other cause, at most once per fault_reset_ms.
  const bool reset = interruptible && p.Out(pf::ModbusOut::kFaultReset).mapped &&
                     reset_rule_.Edge(driver_fault_seen_,
                                      causes_known_.load(std::memory_order_relaxed)
                                          ? status_causes_.load(std::memory_order_relaxed)
                                          : ~0U,
                                      common::MonotonicNs(),
                                      static_cast<std::int64_t>(p.fault_reset_ms) * 1'000'000);
  // Each role's value; roles the [modbus] routing does not drive carry their safe value.
  double v[pf::kNumModbusOut] = {};
  const auto fill = [&](double setpoint, bool enable, bool safe) {
    v[static_cast<std::size_t>(pf::ModbusOut::kCommand)] =
        routed(Output::kCommand) ? setpoint : safe_setpoint_;
    v[static_cast<std::size_t>(pf::ModbusOut::kEnable)] =
        routed(Output::kEnable) && enable && !safe ? 1.0 : 0.0;
    v[static_cast<std::size_t>(pf::ModbusOut::kSafe)] = safe ? 1.0 : 0.0;
    v[static_cast<std::size_t>(pf::ModbusOut::kEcho)] =
        CounterValue(p.Out(pf::ModbusOut::kEcho), c.echo);
    v[static_cast<std::size_t>(pf::ModbusOut::kHeartbeat)] =
        routed(Output::kHeartbeat) ? CounterValue(p.Out(pf::ModbusOut::kHeartbeat), c.tick) : 0.0;
    const bool status = routed(Output::kStatus);
    v[static_cast<std::size_t>(pf::ModbusOut::kStatusSafe)] = status && safe ? 1.0 : 0.0;
    v[static_cast<std::size_t>(pf::ModbusOut::kStatusCauses)] =
        status ? static_cast<double>(status_causes_.load(std::memory_order_relaxed)) : 0.0;
    v[static_cast<std::size_t>(pf::ModbusOut::kStatusOverruns)] = 0.0;     // not carried
    v[static_cast<std::size_t>(pf::ModbusOut::kStatusSafeEntries)] = 0.0;  // not carried
    // Live telemetry; a value its point cannot hold (NaN into an integer) is written as 0.
    const auto live = [&](pf::ModbusOut role, const std::atomic<double>& a) {
      const double x = status ? a.load(std::memory_order_relaxed) : 0.0;
      std::uint16_t scratch[2];
      pf::ModbusPoint at = p.Out(role);
      at.index = 0;
      v[static_cast<std::size_t>(role)] =
          !at.mapped || pf::PutModbusPoint(p, at, x, scratch) ? x : 0.0;
    };
    live(pf::ModbusOut::kStatusModelForce, status_model_force_);
    live(pf::ModbusOut::kStatusDemand, status_demand_);
    live(pf::ModbusOut::kStatusCommand, status_command_);
    v[static_cast<std::size_t>(pf::ModbusOut::kFaultReset)] = reset ? 1.0 : 0.0;
  };
  // Every point must fit before anything is sent; one that does not (a non-finite set-point,
  // a value beyond its type) makes the whole cycle's write the safe one, counted bad_value.
  const auto encodable = [&]() {
    std::uint16_t scratch[2];
    for (std::size_t i = 0; i < pf::kNumModbusOut; ++i) {
      const pf::ModbusPoint& pt = p.outputs[i];
      pf::ModbusPoint at = pt;
      at.index = 0;
      if (pt.mapped && !pf::PutModbusPoint(p, at, v[i], scratch)) return false;
    }
    return true;
  };
  fill(c.setpoint, c.enable, c.safe);
  bool bad = false;
  if (!encodable()) {
    bad = true;
    fill(safe_setpoint_, false, true);
    if (!encodable()) {  // not even the safe values fit: nothing is sent
      *why = IoError::kBadValue;
      Failed(*why, false);
      return Outcome::kFailed;
    }
  }
  bool safe = c.safe || bad;
  // A request the device refuses (an exception, a malformed or timed-out reply) does not end
  // the cycle: the requests after it still go out, with the safe values (set-point of the safe
  // state, enable 0, safe 1), so a driver that refuses one write (e.g. its enable coil) still
  // hears the safe set-point and the heartbeat. Only a broken link ends the cycle at once.
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
      if (!link_->broken()) written_safe_ = safe;  // it went out; its reply will be dropped
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
    Failed(e, false);
    if (failed == IoError::kNone) failed = e;
    if (e == IoError::kDisconnected || link_->broken()) {
      *why = failed;
      return Outcome::kFailed;
    }
    written_safe_ = safe;  // the request went out
    if (!safe) {
      fill(safe_setpoint_, false, true);  // fits (the configuration proves it, safe_state.hpp)
      safe = true;
    }
    if (resync_) {  // RTU: a late or torn reply must not meet the next request
      resync_ = false;
      if (!link_->Quiet(interruptible ? wake_ : -1, waker_.get())) return Outcome::kAbandoned;
    }
  }
  written_safe_ = safe;
  if (failed != IoError::kNone) {
    *why = failed;
    return Outcome::kFailed;
  }
  if (bad) {
    *why = IoError::kBadValue;
    Failed(*why, false);
    return Outcome::kFailed;
  }
  tx_ok_.fetch_add(1, std::memory_order_relaxed);
  return Outcome::kOk;
}

bool ModbusDevice::WriteFixed(const pf::ModbusFixedWrite& w, IoError* why,
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
  Failed(e, e == IoError::kException || e == IoError::kRejectedFrame);
  *why = e;
  return false;
}

bool ModbusDevice::StartUpWrites(Sample* s) {
  for (std::size_t i = 0; i < profile_->startup.size(); ++i) {
    IoError why = IoError::kNone;
    std::uint8_t exception = 0;
    bool ok = false;
    for (int attempt = 0; attempt <= config_.retries && !ok; ++attempt) {  // as other requests
      ok = WriteFixed(profile_->startup[i], &why, &exception);
      if (!ok && (!Retriable(why) || link_->broken())) break;
    }
    if (ok) continue;
    if (why == IoError::kException || why == IoError::kRejectedFrame) {
      startup_exception_.store(exception);
      startup_refused_.store(static_cast<int>(i) + 1);
    }
    tx_failed_.fetch_add(1, std::memory_order_relaxed);
    s->write_failed = config_.outputs != 0 || !profile_->startup.empty();
    s->read_failed = config_.inputs != 0 || config_.lockstep;
    s->why = why;
    return false;
  }
  return true;
}

void ModbusDevice::PeriodicWrites(Sample* s) {
  for (std::size_t i = 0; i < profile_->periodic.size(); ++i) {
    const pf::ModbusFixedWrite& w = profile_->periodic[i];
    const std::int64_t now = common::MonotonicNs();
    if (now < periodic_due_[i]) continue;
    periodic_due_[i] = now + static_cast<std::int64_t>(w.period_ms) * 1'000'000;
    IoError why = IoError::kNone;
    std::uint8_t exception = 0;
    if (WriteFixed(w, &why, &exception)) continue;
    tx_failed_.fetch_add(1, std::memory_order_relaxed);
    s->write_failed = true;
    s->why = why;
    if (link_->broken()) return;
  }
}

}  // namespace mrd::firmware
