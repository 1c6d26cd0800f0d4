// ModbusChannels' worker (modbus_channels.hpp): one link, one thread, every channel's writes
// and the plan's shared reads per cycle. The waits, retries, reconnects and backoff follow
// ModbusDevice's (modbus_device.cpp); nothing here allocates after construction.
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "modbus_channels_parts.hpp"
#include "modbus_link.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/input_roles.hpp"
#include "mrd/firmware/io/modbus/modbus_channels.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/protocol/modbus_frame.hpp"

namespace mrd::firmware {
namespace {

namespace pf = mrd::profile;
namespace mb = mrd::protocol::modbus;

constexpr int kMaxFailedCycles = 3;  // cycles in a row with a timeout, then reconnect
constexpr std::int64_t kBackoffMinNs = 5'000'000;
constexpr std::int64_t kBackoffMaxNs = 200'000'000;
constexpr std::int64_t kLockstepIdleNs = 20'000;              // between reads without a new grant
constexpr std::int64_t kLockstepCommandWaitNs = 100'000'000;  // for the tick's commands

void SleepUntil(std::int64_t t_ns) { (void)common::SleepUntilNs(t_ns); }

void Signal(int fd) {
  if (fd < 0) return;
  const std::uint64_t one = 1;
  (void)!write(fd, &one, sizeof one);
}

// Waits until t_ns or fd's signal (consumed); true when signalled.
bool WaitEventUntil(int fd, std::int64_t t_ns) {
  while (true) {
    const std::int64_t left = t_ns - common::MonotonicNs();
    if (left <= 0) return false;
    const timespec ts{static_cast<time_t>(left / 1'000'000'000),
                      static_cast<long>(left % 1'000'000'000)};
    pollfd p{fd, POLLIN, 0};
    const int r = ppoll(&p, 1, &ts, nullptr);
    if (r > 0) {
      std::uint64_t n = 0;
      (void)!read(fd, &n, sizeof n);
      return true;
    }
    if (r < 0 && errno != EINTR) {
      SleepUntil(t_ns);
      return false;
    }
  }
}

bool Retriable(IoError e) { return e == IoError::kTimeout || e == IoError::kCrc; }

}  // namespace

ModbusChannels::ModbusChannels(const ModbusConfig& config,
                               std::vector<std::shared_ptr<const pf::ModbusProfile>> profiles)
    : config_(config), profiles_(std::move(profiles)) {
  config_.modbus_profile.reset();
  n_ = profiles_.size();
  std::vector<const pf::ModbusProfile*> maps;
  for (const auto& p : profiles_) {
    if (p == nullptr) {
      error_ = "modbus channels: a channel without a map";
      n_ = 0;
      return;
    }
    maps.push_back(p.get());
  }
  if (!pf::PlanModbusChannels(maps, &plan_, &error_)) {
    n_ = 0;
    return;
  }
  if (config_.lockstep && !profiles_[0]->In(pf::CanIn::kGrant).mapped) {
    error_ = profiles_[0]->path + ": lockstep needs the grant input in channel 0's map";
    n_ = 0;
    return;
  }
  // The link's unit: the first read's (set per request anyway).
  link_ = std::make_unique<ModbusLink>(config_);
  waker_ = std::make_unique<Waker>(*this);
  words_ = std::make_unique<std::uint16_t[]>(2000);  // the largest request (bits)
  replies_ = std::make_unique<std::uint8_t[]>((plan_.reads.size() + 1) * mb::kMaxPdu);
  for (std::size_t k = 0; k < n_; ++k) {
    Channel& c = ch_[k];
    c.profile = profiles_[k].get();
    c.command_map = c.profile->command;
    c.safe_setpoint = c.command_map.SafeSetpoint(0.0);
    all_ |= 1U << k;
    for (const auto& w : c.profile->startup) {
      startup_.push_back(&w);
      startup_mask_.push_back(1U << k);
    }
    for (const auto& w : c.profile->periodic) {
      periodic_.push_back(&w);
      periodic_mask_.push_back(1U << k);
    }
  }
  periodic_due_ = std::make_unique<std::int64_t[]>(periodic_.size() + 1);
  for (std::size_t k = 0; k < n_; ++k) views_.push_back(std::make_unique<View>(*this, k));
}

ModbusChannels::~ModbusChannels() {
  if (thread_started_) {
    active_views_ = 1;
    Deactivate();
  }
  link_.reset();
  if (wake_ >= 0) close(wake_);
  if (grant_event_ >= 0) close(grant_event_);
}

bool ModbusChannels::ok(std::string* error) const {
  if (error_.empty()) return true;
  *error = error_;
  return false;
}

bool ModbusChannels::Configure(std::string* error) {
  if (!ok(error)) return false;
  if (configured_) return true;
  if (wake_ < 0) wake_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (config_.lockstep && grant_event_ < 0) grant_event_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_ < 0 || (config_.lockstep && grant_event_ < 0)) {
    *error = std::string("modbus: eventfd: ") + std::strerror(errno);
    return false;
  }
  if (!link_->Create(error)) return false;
  configured_ = true;
  backoff_ns_ = kBackoffMinNs;
  if (link_->Open()) {
    ever_connected_ = true;
  } else {
    const std::string where = config_.mode == ModbusMode::kTcp
                                  ? config_.host + ":" + std::to_string(config_.port)
                                  : config_.device;
    std::fprintf(stderr,
                 "warning: modbus: cannot connect to %s yet (%s); retrying in the "
                 "background, the loop stays in the safe state until data arrives\n",
                 where.c_str(), std::strerror(errno));
  }
  return true;
}

bool ModbusChannels::Activate(std::string* error) {
  if (thread_started_) {
    ++active_views_;
    return true;
  }
  if (!configured_ && !Configure(error)) return false;
  running_.store(true);
  const int rc = pthread_create(
      &thread_, nullptr,
      [](void* self) -> void* {
        auto* d = static_cast<ModbusChannels*>(self);
        if (d->config_.lockstep) {
          d->WorkLockstep();
        } else {
          d->WorkPolling();
        }
        return nullptr;
      },
      this);
  if (rc != 0) {
    running_.store(false);
    *error = std::string("modbus: cannot start the I/O thread: ") + std::strerror(rc);
    return false;
  }
  thread_started_ = true;
  if (link_->open()) {
    // Several requests per cycle: wait (configuration time, bounded) for the first sample or
    // failure, so the loop's first period does not run on a never-sampled frame.
    const std::int64_t wait = config_.response_timeout_ns * (config_.retries + 1) *
                              static_cast<std::int64_t>(1 + plan_.reads.size());
    const std::int64_t until =
        common::MonotonicNs() + (wait < 2'000'000'000 ? wait : 2'000'000'000);
    Sample s;
    const auto sampled = [&] {
      if (!sample_.TryRead(&s)) return false;
      for (std::size_t k = 0; k < n_; ++k) {
        const ChannelSample& c = s.ch[k];
        if (c.accepted > 0 || c.read_failed || c.write_failed) return true;
      }
      return false;
    };
    while (common::MonotonicNs() < until && !sampled()) {
      SleepUntil(common::MonotonicNs() + 100'000);
    }
    if (const int refused = startup_refused_.load(); refused > 0) {
      const std::size_t i = static_cast<std::size_t>(refused - 1);
      const pf::ModbusFixedWrite& w = *startup_[i];
      std::size_t k = 0;
      while (k + 1 < n_ && (startup_mask_[i] & (1U << k)) == 0) ++k;
      char code[8];
      std::snprintf(code, sizeof code, "0x%02X", startup_exception_.load());
      *error = "modbus: " + ch_[k].profile->path + ":" + std::to_string(w.line) +
               ": the start-up write of unit " + std::to_string(w.unit) +
               (w.table == pf::ModbusTable::kCoil ? " coil " : " holding register ") +
               std::to_string(w.address) + " = " + std::to_string(w.value) +
               " was refused (exception " + code + ")";
      return false;
    }
  }
  if (config_.priority > 0) {
    sched_param sp{};
    sp.sched_priority = config_.priority;
    const int err = pthread_setschedparam(thread_, SCHED_FIFO, &sp);
    if (err != 0) {
      std::fprintf(stderr,
                   "warning: modbus: SCHED_FIFO priority %d refused for the I/O thread "
                   "(%s); a safe block may reach the wire later than the loop's period\n",
                   config_.priority, std::strerror(err));
    }
  }
  ++active_views_;
  return true;
}

void ModbusChannels::Deactivate() {
  if (active_views_ > 0 && --active_views_ > 0) return;  // other channels still run
  if (thread_started_) {
    running_.store(false);
    Signal(wake_);
    pthread_join(thread_, nullptr);
    thread_started_ = false;
  }
  if (!configured_) return;
  // Each channel's last posted block, unless its driver acknowledged it already (as the
  // one-channel device: in lockstep the worker never writes the shutdown's block).
  for (std::size_t k = 0; k < n_; ++k) {
    Channel& ch = ch_[k];
    const Command last = ch.command.version() != 0 ? ch.command.Read() : Command{};
    const bool acknowledged =
        ch.safe_acknowledged && last.safe && last.tick == ch.safe_acknowledged_tick;
    if (acknowledged || !link_->open() || link_->broken() ||
        (config_.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) == 0) {
      continue;
    }
    Command safe;
    safe.tick = last.tick + 1;
    safe.echo = ch.last_seq;
    safe.setpoint = ch.safe_setpoint;
    IoError why = IoError::kNone;
    if (WriteChannel(k, safe, &why, /*interruptible=*/false) != Outcome::kOk) {
      ch.counters.tx_failed.fetch_add(1, std::memory_order_relaxed);
    }
  }
  link_->Close();
}

void ModbusChannels::Failed(IoError e, bool reply_refused, std::uint32_t mask) {
  for (std::size_t k = 0; k < n_; ++k) {
    if ((mask & (1U << k)) == 0) continue;
    Counters& c = ch_[k].counters;
    c.errors[static_cast<std::size_t>(e)].fetch_add(1, std::memory_order_relaxed);
    c.last_error.store(static_cast<std::uint8_t>(e), std::memory_order_relaxed);
    if (reply_refused) c.rx_rejected.fetch_add(1, std::memory_order_relaxed);
  }
  if (e == IoError::kTimeout) timed_out_ = true;
  if (config_.mode == ModbusMode::kRtu &&
      (e == IoError::kTimeout || e == IoError::kCrc || e == IoError::kRejectedFrame)) {
    resync_ = true;
  }
}

void ModbusChannels::GoodExchange() { backoff_ns_ = kBackoffMinNs; }

void ModbusChannels::FailAll(Sample* s, std::uint32_t mask, bool reads, bool writes, IoError why) {
  for (std::size_t k = 0; k < n_; ++k) {
    if ((mask & (1U << k)) == 0) continue;
    if (reads) s->ch[k].read_failed = true;
    if (writes) s->ch[k].write_failed = true;
    s->ch[k].why = why;
  }
}

bool ModbusChannels::Connect(Sample* s) {
  if (link_->open()) return true;
  if (common::MonotonicNs() < connect_at_ns_) {
    WaitEventUntil(wake_, connect_at_ns_);
    return false;
  }
  if (!link_->Open()) {
    Failed(IoError::kDisconnected, false, all_);
    FailAll(s, all_, config_.inputs != 0 || config_.lockstep, config_.outputs != 0,
            IoError::kDisconnected);
    sample_.Write(*s);
    connect_at_ns_ = common::MonotonicNs() + backoff_ns_;
    backoff_ns_ = backoff_ns_ * 2 > kBackoffMaxNs ? kBackoffMaxNs : backoff_ns_ * 2;
    return false;
  }
  if (ever_connected_) {
    for (std::size_t k = 0; k < n_; ++k) {
      ch_[k].counters.reconnects.fetch_add(1, std::memory_order_relaxed);
    }
  }
  ever_connected_ = true;
  resync_ = false;
  unanswered_since_ns_ = 0;
  for (std::size_t k = 0; k < n_; ++k) ch_[k].have_seq = false;
  started_ = false;
  for (std::size_t i = 0; i < periodic_.size(); ++i) periodic_due_[i] = 0;
  return true;
}

void ModbusChannels::EndSession() {
  link_->Close();
  connect_at_ns_ = common::MonotonicNs() + backoff_ns_;
  backoff_ns_ = backoff_ns_ * 2 > kBackoffMaxNs ? kBackoffMaxNs : backoff_ns_ * 2;
}

bool ModbusChannels::SafePending() const {
  for (std::size_t k = 0; k < n_; ++k) {
    const Channel& ch = ch_[k];
    if (ch.written_safe || ch.command.version() == 0) continue;
    const Command c = ch.command.Read();
    if (c.safe && (!ch.any_written || c.tick != ch.written_tick)) return true;
  }
  return false;
}

ModbusChannels::Outcome ModbusChannels::WriteAll(Sample* s) {
  const std::uint64_t released = released_tick_.load(std::memory_order_acquire);
  Outcome result = Outcome::kNothing;
  for (std::size_t k = 0; k < n_; ++k) {
    Channel& ch = ch_[k];
    if (ch.command.version() == 0) continue;
    Command c = ch.command.Read();
    if (ch.any_written && c.tick == ch.written_tick) continue;
    if (config_.lockstep && c.tick >= released) continue;  // not published by every channel
    IoError why = IoError::kNone;
    Outcome o = Outcome::kFailed;
    for (int attempt = 0; attempt <= config_.retries;) {
      if (resync_) {
        resync_ = false;
        (void)link_->Quiet(wake_, waker_.get());
      }
      if (!running_.load(std::memory_order_relaxed)) return Outcome::kAbandoned;
      if (!config_.lockstep) c = ch.command.Read();  // the newest block, as it is written
      o = WriteChannel(k, c, &why, /*interruptible=*/true);
      if (o == Outcome::kOk) break;
      if (o == Outcome::kAbandoned) {
        if (!running_.load(std::memory_order_relaxed) || link_->broken()) return o;
        continue;  // a safe block supersedes the one in flight
      }
      if (!Retriable(why) || link_->broken()) break;
      ++attempt;
    }
    if (o == Outcome::kOk) {
      s->ch[k].write_failed = false;
      ch.safe_acknowledged = c.safe;
      ch.safe_acknowledged_tick = c.tick;
      if (result == Outcome::kNothing) result = Outcome::kOk;
    } else {
      ch.counters.tx_failed.fetch_add(1, std::memory_order_relaxed);
      s->ch[k].write_failed = true;
      s->ch[k].why = why;
      result = Outcome::kFailed;
      if (link_->broken()) break;
    }
  }
  if (config_.lockstep && released != 0) {
    bool all = true;
    for (std::size_t k = 0; k < n_; ++k) {
      all = all && ch_[k].any_written && ch_[k].written_tick + 1 >= released;
    }
    if (all) {
      handled_tick_.store(released - 1, std::memory_order_release);
      handled_any_.store(true, std::memory_order_release);
    }
  }
  return result;
}

ModbusChannels::Outcome ModbusChannels::ReadAll(Sample* s, bool* new_grant) {
  const std::size_t nreads = plan_.reads.size();
  std::uint32_t failed = 0;  // channels with a failed request
  std::int64_t stamp_ns = 0;
  bool stamped = false;
  for (std::size_t q = 0; q < nreads; ++q) {
    const pf::ModbusRequest& req = plan_.reads[q];
    const std::uint32_t mask = plan_.served[q];
    std::uint8_t pdu[8];
    std::uint8_t* reply = replies_.get() + q * mb::kMaxPdu;
    const int len = pf::PutModbusRead(req, pdu);
    IoError why = IoError::kNone;
    bool ok = false;
    for (int attempt = 0; attempt <= config_.retries; ++attempt) {
      if (resync_) {
        resync_ = false;
        if (!link_->Quiet(wake_, waker_.get())) return Outcome::kAbandoned;
      }
      if (!running_.load(std::memory_order_relaxed)) return Outcome::kAbandoned;
      const std::int64_t sent_ns = common::MonotonicNs();
      const bool rtu = config_.mode == ModbusMode::kRtu;
      if (!stamped) {  // the sample is no older than the cycle's first request
        stamp_ns = rtu && unanswered_since_ns_ != 0 ? unanswered_since_ns_ : sent_ns;
        stamped = true;
      }
      link_->set_unit(req.unit);
      int reply_len = 0;
      const ModbusLink::Result r =
          link_->Transact(pdu, len, reply, &reply_len, &why, wake_, waker_.get());
      if (rtu && r != ModbusLink::Result::kOk && unanswered_since_ns_ == 0) {
        unanswered_since_ns_ = sent_ns;
      }
      if (r == ModbusLink::Result::kAbandoned) return Outcome::kAbandoned;
      if (r == ModbusLink::Result::kOk) {
        std::uint8_t exception = 0;
        const pf::ModbusReply check = pf::CheckModbusRead(req, reply, reply_len, &exception);
        if (check == pf::ModbusReply::kOk) {
          ok = true;
          break;
        }
        why = check == pf::ModbusReply::kException ? IoError::kException : IoError::kRejectedFrame;
        Failed(why, true, mask);
      } else {
        Failed(why, why != IoError::kTimeout && why != IoError::kDisconnected, mask);
      }
      if (!Retriable(why) || link_->broken()) break;
    }
    if (ok) {
      GoodExchange();
      continue;
    }
    failed |= mask;
    FailAll(s, mask, true, false, why);
    if (link_->broken() || timed_out_) {  // the link is suspect: the rest waits a cycle
      for (std::size_t r = q + 1; r < nreads; ++r) failed |= plan_.served[r];
      FailAll(s, failed, true, false, why);
      break;
    }
  }
  if (failed == 0) unanswered_since_ns_ = 0;
  // Lockstep: the grant [us] (channel 0's role) follows its step's sensor values.
  std::int64_t stamp = stamp_ns;
  if (config_.lockstep) {
    if ((failed & 1U) != 0) return Outcome::kFailed;  // no grant this cycle
    const pf::ModbusPoint& gp = plan_.inputs[0][static_cast<std::size_t>(pf::CanIn::kGrant)];
    const double g =
        pf::ModbusPointValue(*ch_[0].profile, gp, replies_.get() + gp.request * mb::kMaxPdu);
    const auto grant = g > 0.0 && g < 9e12 ? static_cast<std::int64_t>(std::llround(g * 1e3)) : 0;
    *new_grant = grant > s->grant_ns;
    if (*new_grant) s->grant_ns = grant;
    stamp = s->grant_ns;
    if (s->grant_ns == 0) {  // before the first grant: good reads, no data
      for (std::size_t k = 0; k < n_; ++k) {
        if ((failed & (1U << k)) == 0) s->ch[k].read_failed = false;
      }
      return failed == 0 ? Outcome::kOk : Outcome::kFailed;
    }
  }
  for (std::size_t k = 0; k < n_; ++k) {
    if ((failed & (1U << k)) != 0) continue;
    // Lockstep: the reads between grants re-read the step's values (the harness stores a
    // step with its grant): decoded (and a bad value counted) once per step and channel.
    if (config_.lockstep && decoded_grant_[k] == s->grant_ns) continue;
    decoded_grant_[k] = s->grant_ns;
    double values[pf::kNumCanIn] = {};
    for (std::size_t i = 0; i < pf::kNumCanIn; ++i) {
      const pf::ModbusPoint& pt = plan_.inputs[k][i];
      if (pt.mapped) {
        values[i] =
            pf::ModbusPointValue(*ch_[k].profile, pt, replies_.get() + pt.request * mb::kMaxPdu);
      }
    }
    Decode(k, values, stamp, s);
  }
  return failed == 0 ? Outcome::kOk : Outcome::kFailed;
}

// Channel k's values from a cycle whose requests for it all succeeded.
void ModbusChannels::Decode(std::size_t k, const double* values, std::int64_t stamp, Sample* out) {
  Channel& ch = ch_[k];
  ChannelSample& s = out->ch[k];
  const pf::ModbusProfile& p = *ch.profile;
  for (std::size_t i = 0; i < pf::kNumCanIn; ++i) {
    if (p.inputs[i].mapped && !std::isfinite(values[i])) {  // a float32 NaN or infinity
      Failed(IoError::kBadValue, true, 1U << k);
      s.read_failed = true;
      s.why = IoError::kBadValue;
      return;
    }
  }
  const auto value = [&](pf::CanIn r) { return values[static_cast<std::size_t>(r)]; };
  s.read_failed = false;
  const bool has_seq = p.In(pf::CanIn::kSensorSeq).mapped;
  const double sv = value(pf::CanIn::kSensorSeq);
  const std::uint32_t seq = !has_seq                         ? s.seq + 1
                            : sv >= 0.0 && sv < 4294967296.0 ? static_cast<std::uint32_t>(sv)
                                                             : 0U;
  s.fault_line = value(pf::CanIn::kFaultLine) != 0.0;
  s.driver_fault = value(pf::CanIn::kDriverFaults) != 0.0;
  ch.driver_fault_seen = s.driver_fault;
  if (!ch.have_seq || seq != s.seq) {  // a repeated seq is not new data
    ch.have_seq = true;
    s.seq = seq;
    s.stamp_ns = stamp;
    for (const InputRole& m : kInputRoles) {
      if (m.input != Input::kFaultLine) s.values[static_cast<std::size_t>(m.input)] = value(m.role);
    }
    ++s.accepted;
    ch.counters.rx_ok.fetch_add(1, std::memory_order_relaxed);
  }
}

ModbusChannels::CycleEnd ModbusChannels::Cycle(Sample* s, int* timed_out_cycles, bool* new_grant) {
  *new_grant = false;
  if (!Connect(s)) {
    *timed_out_cycles = 0;
    return CycleEnd::kNoSession;
  }
  const bool reads = config_.inputs != 0 || config_.lockstep;
  const bool writes = config_.outputs != 0;
  timed_out_ = false;
  if (!started_) {
    if (!StartUpWrites(s)) {
      sample_.Write(*s);
      EndSession();
      *timed_out_cycles = 0;
      return CycleEnd::kSessionEnded;
    }
    started_ = true;
  }
  Outcome w = Outcome::kNothing, r = Outcome::kNothing;
  if (writes) w = WriteAll(s);
  if (reads && w != Outcome::kAbandoned && !link_->broken()) r = ReadAll(s, new_grant);
  if (w != Outcome::kAbandoned && r != Outcome::kAbandoned && !link_->broken()) PeriodicWrites(s);
  for (std::size_t k = 0; k < n_; ++k) {
    if (!s->ch[k].read_failed && !s->ch[k].write_failed) s->ch[k].why = IoError::kNone;
  }
  sample_.Write(*s);
  *timed_out_cycles = timed_out_ ? *timed_out_cycles + 1 : 0;
  if (link_->broken() || *timed_out_cycles >= kMaxFailedCycles) {
    EndSession();
    *timed_out_cycles = 0;
    return CycleEnd::kSessionEnded;
  }
  if (w == Outcome::kAbandoned || r == Outcome::kAbandoned) return CycleEnd::kAbandoned;
  return CycleEnd::kDone;
}

void ModbusChannels::WorkPolling() {
  Sample s;
  int timed_out_cycles = 0;
  std::int64_t next = common::MonotonicNs();
  while (running_.load(std::memory_order_relaxed)) {
    bool new_grant = false;
    const CycleEnd end = Cycle(&s, &timed_out_cycles, &new_grant);
    if (end == CycleEnd::kNoSession) next = common::MonotonicNs();
    if (end != CycleEnd::kDone) continue;
    next += config_.poll_period_ns;
    const std::int64_t now = common::MonotonicNs();
    if (next < now) next = now;
    if (!SafePending()) (void)WaitEventUntil(wake_, next);
  }
}

void ModbusChannels::WorkLockstep() {
  Sample s;
  int timed_out_cycles = 0;
  while (running_.load(std::memory_order_relaxed)) {
    bool new_grant = false;
    if (Cycle(&s, &timed_out_cycles, &new_grant) != CycleEnd::kDone) continue;
    if (new_grant) {
      Signal(grant_event_);
      (void)WaitEventUntil(wake_, common::MonotonicNs() + kLockstepCommandWaitNs);
    } else {
      SleepUntil(common::MonotonicNs() + kLockstepIdleNs);
    }
  }
}

bool ModbusChannels::WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) {
  const std::int64_t until = common::MonotonicNs() + timeout_ns;
  while (true) {
    Sample s;
    bool got = false;
    for (int i = 0; i < 4 && !got; ++i) got = sample_.TryRead(&s);
    if (got && s.grant_ns > granted_ns_) {
      granted_ns_ = s.grant_ns;
      *t_ns = granted_ns_;
      return true;
    }
    const std::int64_t now = common::MonotonicNs();
    if (now >= until) break;
    const std::int64_t wait = until - now;
    const timespec ts{static_cast<time_t>(wait / 1'000'000'000),
                      static_cast<long>(wait % 1'000'000'000)};
    pollfd p{grant_event_, POLLIN, 0};
    if (ppoll(&p, 1, &ts, nullptr) > 0) {
      std::uint64_t n = 0;
      (void)!read(grant_event_, &n, sizeof n);
    }
  }
  return false;
}

}  // namespace mrd::firmware
