#include "mrd/firmware/io/modbus/modbus_device.hpp"

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
#include <memory>

#include "modbus_link.hpp"
#include "modbus_waker.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/devices.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/protocol/modbus_frame.hpp"
#include "mrd/protocol/modbus_map.hpp"

namespace mrd::firmware {
namespace {

namespace map = mrd::protocol::modbus;

constexpr int kMaxFailedCycles = 3;  // cycles in a row with a timeout, then reconnect
constexpr std::int64_t kBackoffMinNs = 5'000'000;
constexpr std::int64_t kBackoffMaxNs = 200'000'000;
constexpr int kReadAttempts = 4;  // seqlock attempts per Read on the tick

constexpr std::int64_t kLockstepIdleNs = 20'000;              // between reads without a new grant
constexpr std::int64_t kLockstepCommandWaitNs = 100'000'000;  // for the tick's command
constexpr std::int64_t kLockstepHandOverNs = 100'000'000;     // the worker writing a published tick

// Short worker pauses; a failing sleep (never with CLOCK_MONOTONIC) just ends the pause.
void SleepUntil(std::int64_t t_ns) { (void)common::SleepUntilNs(t_ns); }

// eventfd wake-ups. Signal never blocks (a full counter is already a wake-up).
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

ModbusDevice::ModbusDevice(const ModbusConfig& config)
    : config_(config),
      profile_(config.modbus_profile.get()),
      link_(std::make_unique<ModbusLink>(config)),
      waker_(std::make_unique<Waker>(*this)) {
  if (profile_ != nullptr) {
    command_map_ = profile_->command;
    safe_setpoint_ = command_map_.SafeSetpoint(0.0);   // the driver's off (proved at load)
    words_ = std::make_unique<std::uint16_t[]>(2000);  // the largest request (bits)
    periodic_due_ = std::make_unique<std::int64_t[]>(profile_->periodic.size() + 1);
  }
}

ModbusDevice::~ModbusDevice() {
  Deactivate();
  link_.reset();
  if (wake_ >= 0) close(wake_);
  if (grant_event_ >= 0) close(grant_event_);
}

bool ModbusDevice::Configure(std::string* error) {
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

bool ModbusDevice::Activate(std::string* error) {
  if (thread_started_) return true;
  if (!configured_ && !Configure(error)) return false;
  running_.store(true);
  const int rc = pthread_create(&thread_, nullptr, &ModbusDevice::WorkerMain, this);
  if (rc != 0) {
    running_.store(false);
    *error = std::string("modbus: cannot start the I/O thread: ") + std::strerror(rc);
    return false;
  }
  thread_started_ = true;
  if (profile_ != nullptr && link_->open()) {
    // A profile's cycle is several requests: wait (configuration time, bounded) for its first
    // sample or failure, so the loop's first period does not run on a never-sampled frame.
    const std::int64_t wait = config_.response_timeout_ns * (config_.retries + 1) *
                              static_cast<std::int64_t>(1 + profile_->reads.size());
    const std::int64_t until =
        common::MonotonicNs() + (wait < 2'000'000'000 ? wait : 2'000'000'000);
    Sample s;
    while (common::MonotonicNs() < until &&
           !(sample_.TryRead(&s) && (s.accepted > 0 || s.read_failed || s.write_failed))) {
      SleepUntil(common::MonotonicNs() + 100'000);
    }
    if (const int refused = startup_refused_.load(); refused > 0) {
      const profile::ModbusFixedWrite& w = profile_->startup[static_cast<std::size_t>(refused - 1)];
      char code[8];
      std::snprintf(code, sizeof code, "0x%02X", startup_exception_.load());
      *error = "modbus: " + profile_->path + ":" + std::to_string(w.line) +
               ": the start-up write of unit " + std::to_string(w.unit) +
               (w.table == profile::ModbusTable::kCoil ? " coil " : " holding register ") +
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
  return true;
}

void ModbusDevice::Deactivate() {
  if (thread_started_) {
    running_.store(false);
    Signal(wake_);  // every wait of the worker watches it
    pthread_join(thread_, nullptr);
    thread_started_ = false;
  }
  if (!configured_) return;
  // The worker (stopped now) may already have had the driver acknowledge the safe block the
  // loop posted last (its shutdown): that is the final safe state. Writing it again would only
  // make the request count depend on whether the worker got there before it stopped. In
  // lockstep the worker never writes that block (released_tick_): it is always written here.
  const Command last = command_.version() != 0 ? command_.Read() : Command{};
  const bool acknowledged = safe_acknowledged_ && last.safe && last.tick == safe_acknowledged_tick_;
  if (!acknowledged && link_->open() && !link_->broken() &&
      (config_.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) != 0) {
    Command safe;
    safe.tick = command_.Read().tick + 1;
    safe.echo = last_seq_;
    safe.setpoint = safe_setpoint_;
    IoError why = IoError::kNone;
    // Best effort, one attempt: the peer may be gone.
    if (WriteOnce(safe, &why, /*interruptible=*/false) != Outcome::kOk) {
      tx_failed_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  link_->Close();
}

void* ModbusDevice::WorkerMain(void* self) {
  static_cast<ModbusDevice*>(self)->Work();
  return nullptr;
}

void ModbusDevice::Count(IoError e) {
  errors_[static_cast<std::size_t>(e)].fetch_add(1, std::memory_order_relaxed);
  last_error_.store(static_cast<std::uint8_t>(e), std::memory_order_relaxed);
}

void ModbusDevice::Failed(IoError e, bool reply_refused) {
  Count(e);
  if (reply_refused) rx_rejected_.fetch_add(1, std::memory_order_relaxed);
  if (e == IoError::kTimeout) timed_out_ = true;
  // RTU has no transaction id: a late or torn reply must not meet the next request.
  if (config_.mode == ModbusMode::kRtu &&
      (e == IoError::kTimeout || e == IoError::kCrc || e == IoError::kRejectedFrame)) {
    resync_ = true;
  }
}

void ModbusDevice::GoodExchange() {
  session_good_ = true;
  backoff_ns_ = kBackoffMinNs;
}

bool ModbusDevice::Connect(Sample* s) {
  if (link_->open()) return true;
  if (common::MonotonicNs() < connect_at_ns_) {  // backoff after a failed session or connect
    WaitEventUntil(wake_, connect_at_ns_);
    return false;
  }
  if (!link_->Open()) {
    Count(IoError::kDisconnected);
    s->read_failed = config_.inputs != 0 || config_.lockstep;
    s->write_failed = config_.outputs != 0;
    s->why = IoError::kDisconnected;
    sample_.Write(*s);
    connect_at_ns_ = common::MonotonicNs() + backoff_ns_;
    backoff_ns_ = backoff_ns_ * 2 > kBackoffMaxNs ? kBackoffMaxNs : backoff_ns_ * 2;
    return false;
  }
  if (ever_connected_) reconnects_.fetch_add(1, std::memory_order_relaxed);
  ever_connected_ = true;
  session_good_ = false;
  resync_ = false;
  unanswered_since_ns_ = 0;
  have_seq_ = false;  // a new peer may restart its sequence
  started_ = false;   // the profile's start-up writes go out again, periodic ones at once
  if (periodic_due_ != nullptr) {
    for (std::size_t i = 0; i < profile_->periodic.size(); ++i) periodic_due_[i] = 0;
  }
  return true;
}

void ModbusDevice::EndSession() {
  link_->Close();
  // Every session that ends is followed by the backoff; it doubles while sessions fail
  // without one good exchange (a peer that accepts and resets is not hammered).
  connect_at_ns_ = common::MonotonicNs() + backoff_ns_;
  backoff_ns_ = backoff_ns_ * 2 > kBackoffMaxNs ? kBackoffMaxNs : backoff_ns_ * 2;
}

bool ModbusDevice::LatestCommand(Command* c) const {
  if (command_.version() == 0) return false;
  *c = command_.Read();
  return true;
}

bool ModbusDevice::SafePending() const {
  Command c;
  return !written_safe_ && LatestCommand(&c) && c.safe &&
         (!any_written_ || c.tick != written_tick_);
}

ModbusDevice::Outcome ModbusDevice::WriteOnce(const Command& c, IoError* why, bool interruptible) {
  if (profile_ != nullptr) return WriteProfileOnce(c, why, interruptible);
  map::CommandBlock b;
  b.echo = c.echo;
  b.has_set_point = (config_.outputs & Bit(Output::kCommand)) != 0;
  b.set_point = c.volts;
  b.enable_driven = (config_.outputs & Bit(Output::kEnable)) != 0;
  b.enable = c.enable && !c.safe;
  b.heartbeat = (config_.outputs & Bit(Output::kHeartbeat)) != 0
                    ? static_cast<std::uint16_t>(c.tick & 0xFFFFU)
                    : 0;
  b.safe = c.safe;
  b.has_status = (config_.outputs & Bit(Output::kStatus)) != 0;
  b.causes = status_causes_.load(std::memory_order_relaxed);
  b.ticks = status_ticks_.load(std::memory_order_relaxed);
  written_tick_ = c.tick;  // sent or failed, a command is not sent again
  any_written_ = true;
  std::uint16_t regs[map::kCommandCount] = {};
  if (map::EncodeCommand(b, regs) != map::MapError::kOk) {
    *why = IoError::kBadValue;  // a set-point outside the register's range is not sent
    Failed(*why, false);
    return Outcome::kFailed;
  }
  std::uint8_t pdu[map::kMaxPdu], reply[map::kMaxPdu];
  const int len = map::PutWriteRequest(map::kCommandBase, regs, map::kCommandCount, pdu);
  int reply_len = 0;
  writing_safe_ = c.safe;
  const ModbusLink::Result r =
      link_->Transact(pdu, len, reply, &reply_len, why, interruptible ? wake_ : -1, waker_.get());
  writing_safe_ = false;
  if (r == ModbusLink::Result::kAbandoned) {
    if (!link_->broken()) written_safe_ = c.safe;  // it went out; its reply will be dropped
    return Outcome::kAbandoned;
  }
  if (r == ModbusLink::Result::kOk) {
    std::uint8_t exception = 0;
    switch (
        map::CheckWriteReply(reply, reply_len, map::kCommandBase, map::kCommandCount, &exception)) {
      case map::Reply::kOk:
        tx_ok_.fetch_add(1, std::memory_order_relaxed);
        written_safe_ = c.safe;
        GoodExchange();
        return Outcome::kOk;
      case map::Reply::kException:
        *why = IoError::kException;
        break;
      case map::Reply::kMalformed:
        *why = IoError::kRejectedFrame;
        break;
    }
  }
  if (*why != IoError::kDisconnected) written_safe_ = c.safe;  // the request went out
  Failed(*why, false);
  return Outcome::kFailed;
}

ModbusDevice::Outcome ModbusDevice::WriteLatest(Sample* s) {
  Command c;
  if (!LatestCommand(&c) || (any_written_ && c.tick == written_tick_)) return Outcome::kNothing;
  if (config_.lockstep && c.tick >= released_tick_.load(std::memory_order_acquire)) {
    return Outcome::kNothing;  // not published (yet): see released_tick_
  }
  IoError why = IoError::kNone;
  for (int attempt = 0; attempt <= config_.retries;) {
    if (resync_) {
      resync_ = false;
      (void)link_->Quiet(wake_, waker_.get());  // gives way to a safe block
    }
    if (!running_.load(std::memory_order_relaxed)) return Outcome::kAbandoned;
    // The newest block, at the moment it is written (lockstep: the released one, read above;
    // a safe block never supersedes it there).
    if (!config_.lockstep) (void)LatestCommand(&c);
    const Outcome o = WriteOnce(c, &why, /*interruptible=*/true);
    if (o != Outcome::kAbandoned) {
      handled_tick_.store(c.tick, std::memory_order_release);
      handled_any_.store(true, std::memory_order_release);
    }
    if (o == Outcome::kOk) {
      s->write_failed = false;
      safe_acknowledged_ = c.safe;
      safe_acknowledged_tick_ = c.tick;
      return o;
    }
    if (o == Outcome::kAbandoned) {
      if (!running_.load(std::memory_order_relaxed) || link_->broken()) return o;
      continue;  // a safe block supersedes the one in flight: written now, not a retry
    }
    if (!Retriable(why) || link_->broken()) break;
    ++attempt;
  }
  tx_failed_.fetch_add(1, std::memory_order_relaxed);
  s->write_failed = true;
  s->why = why;
  return Outcome::kFailed;
}

ModbusDevice::Outcome ModbusDevice::ReadOnce(const std::uint8_t* pdu, int len, std::uint8_t* reply,
                                             int* reply_len, IoError* why, std::int64_t* stamp_ns) {
  if (resync_) {
    resync_ = false;
    if (!link_->Quiet(wake_, waker_.get())) return Outcome::kAbandoned;
  }
  if (!running_.load(std::memory_order_relaxed)) return Outcome::kAbandoned;
  // The reply's values are no older than this request: its stamp (however late the reply).
  // RTU has no transaction id: while an earlier read may still be answered late, the
  // stamp is that read's (the reply taken may be its).
  const std::int64_t sent_ns = common::MonotonicNs();
  const bool rtu = config_.mode == ModbusMode::kRtu;
  *stamp_ns = rtu && unanswered_since_ns_ != 0 ? unanswered_since_ns_ : sent_ns;
  const ModbusLink::Result r =
      link_->Transact(pdu, len, reply, reply_len, why, wake_, waker_.get());
  if (rtu && r != ModbusLink::Result::kOk && unanswered_since_ns_ == 0) {
    unanswered_since_ns_ = sent_ns;
  }
  switch (r) {
    case ModbusLink::Result::kOk:
      return Outcome::kOk;
    case ModbusLink::Result::kAbandoned:
      return Outcome::kAbandoned;
    case ModbusLink::Result::kFailed:
      break;
  }
  return Outcome::kFailed;
}

bool ModbusDevice::BeforeFirstGrant(Sample* s) const {
  if (!config_.lockstep || s->grant_ns != 0) return false;
  s->read_failed = false;
  return true;
}

ModbusDevice::Outcome ModbusDevice::ReadSensors(Sample* out, bool* new_grant) {
  if (profile_ != nullptr) return ReadProfile(out, new_grant);
  Sample& s = *out;
  const int count = config_.lockstep ? map::kLockstepSensorCount : map::kSensorCount;
  std::uint8_t pdu[8], reply[map::kMaxPdu];
  const int len = map::PutReadRequest(map::kSensorBase, count, pdu);
  IoError why = IoError::kNone;
  for (int attempt = 0; attempt <= config_.retries; ++attempt) {
    int reply_len = 0;
    std::int64_t stamp_ns = 0;
    const Outcome r = ReadOnce(pdu, len, reply, &reply_len, &why, &stamp_ns);
    if (r == Outcome::kAbandoned) return Outcome::kAbandoned;
    if (r == Outcome::kOk) {
      std::uint16_t regs[map::kLockstepSensorCount] = {};
      std::uint8_t exception = 0;
      const map::Reply check = map::CheckReadReply(reply, reply_len, count, regs, &exception);
      if (check == map::Reply::kOk) {
        GoodExchange();
        unanswered_since_ns_ = 0;
        std::int64_t stamp = stamp_ns;
        if (config_.lockstep) {
          // The grant follows its step's sensor values: they are stamped with it.
          const auto grant = static_cast<std::int64_t>(map::GetU48(regs + map::kGrant)) * 1000;
          *new_grant = grant > s.grant_ns;
          if (*new_grant) s.grant_ns = grant;
          stamp = s.grant_ns;
        }
        if (BeforeFirstGrant(&s)) return Outcome::kOk;
        map::SensorBlock b;
        if (map::DecodeSensors(regs, &b) != map::MapError::kOk) {
          why = IoError::kBadValue;  // a well-formed reply with undefined bits: not retried
          Failed(why, true);
          break;
        }
        s.read_failed = false;
        s.fault_line = b.fault_line;         // on every good read, as the profile's
        s.driver_fault = b.driver_fault;     // honoured whether or not fault_line is routed
        if (!have_seq_ || b.seq != s.seq) {  // a repeated seq is not new data
          have_seq_ = true;
          s.seq = b.seq;
          s.stamp_ns = stamp;
          s.value(Input::kVelocity) = b.velocity;
          s.value(Input::kDisplacement) = b.displacement;
          s.value(Input::kDemand) = b.demand;
          s.value(Input::kBodyVelocity) = b.body_velocity;
          s.value(Input::kForce) = b.force;
          ++s.accepted;
          rx_ok_.fetch_add(1, std::memory_order_relaxed);
        }
        return Outcome::kOk;
      }
      why = check == map::Reply::kException ? IoError::kException : IoError::kRejectedFrame;
      Failed(why, true);
    } else {
      // A reply that came and was refused (CRC, unit id, framing) counts as rejected.
      Failed(why, why != IoError::kTimeout && why != IoError::kDisconnected);
    }
    if (!Retriable(why) || link_->broken()) break;
  }
  s.read_failed = true;
  s.why = why;
  return Outcome::kFailed;
}

void ModbusDevice::Work() {
  if (config_.lockstep) {
    WorkLockstep();
  } else {
    WorkPolling();
  }
}

ModbusDevice::CycleEnd ModbusDevice::Cycle(Sample* s, int* timed_out_cycles, bool* new_grant) {
  *new_grant = false;
  if (!Connect(s)) {
    *timed_out_cycles = 0;
    return CycleEnd::kNoSession;
  }
  const bool reads = config_.inputs != 0 || config_.lockstep;
  const bool writes = config_.outputs != 0;
  timed_out_ = false;
  if (profile_ != nullptr && !started_) {
    if (!StartUpWrites(s)) {
      sample_.Write(*s);
      EndSession();
      *timed_out_cycles = 0;
      return CycleEnd::kSessionEnded;
    }
    started_ = true;
  }
  Outcome w = Outcome::kNothing, r = Outcome::kNothing;
  if (writes) w = WriteLatest(s);
  if (reads && w != Outcome::kAbandoned && !link_->broken()) r = ReadSensors(s, new_grant);
  if (profile_ != nullptr && w != Outcome::kAbandoned && r != Outcome::kAbandoned &&
      !link_->broken()) {
    PeriodicWrites(s);
  }
  if (!s->read_failed && !s->write_failed) s->why = IoError::kNone;
  sample_.Write(*s);

  // Only link failures reconnect: a protocol-level failure (exception, refused frame, bad
  // value, CRC) keeps a link that carries frames.
  *timed_out_cycles = timed_out_ ? *timed_out_cycles + 1 : 0;
  if (link_->broken() || *timed_out_cycles >= kMaxFailedCycles) {
    EndSession();
    *timed_out_cycles = 0;
    return CycleEnd::kSessionEnded;
  }
  if (w == Outcome::kAbandoned || r == Outcome::kAbandoned) return CycleEnd::kAbandoned;
  return CycleEnd::kDone;
}

void ModbusDevice::WorkPolling() {
  Sample s;  // the worker's copy of what it publishes
  int timed_out_cycles = 0;
  std::int64_t next = common::MonotonicNs();
  while (running_.load(std::memory_order_relaxed)) {
    bool new_grant = false;  // never set: no time register read outside lockstep
    const CycleEnd end = Cycle(&s, &timed_out_cycles, &new_grant);
    if (end == CycleEnd::kNoSession) next = common::MonotonicNs();
    if (end != CycleEnd::kDone) continue;  // reconnect, or a safe block now
    next += config_.poll_period_ns;
    const std::int64_t now = common::MonotonicNs();
    if (next < now) next = now;  // behind (slow peer): no catch-up burst
    if (!SafePending()) (void)WaitEventUntil(wake_, next);
  }
}

void ModbusDevice::WorkLockstep() {
  Sample s;  // the worker's copy of what it publishes
  int timed_out_cycles = 0;
  while (running_.load(std::memory_order_relaxed)) {
    bool new_grant = false;
    if (Cycle(&s, &timed_out_cycles, &new_grant) != CycleEnd::kDone) continue;
    // A new grant: wake the loop, wait for its tick's command (written at the top of the
    // next cycle). Else read again soon: the harness sets the next grant after our command.
    if (new_grant) {
      Signal(grant_event_);
      (void)WaitEventUntil(wake_, common::MonotonicNs() + kLockstepCommandWaitNs);
    } else {
      SleepUntil(common::MonotonicNs() + kLockstepIdleNs);
    }
  }
}

IoStatus ModbusDevice::Read(const IoTime& t, SensorFrame* frame, IoError* why) {
  (void)t;  // the samples carry their requests' stamps (worker thread)
  bool got = false;
  for (int i = 0; i < kReadAttempts && !got; ++i) got = sample_.TryRead(&cached_);
  const Sample& s = cached_;  // the worker is publishing right now: the previous copy
  last_write_failed_ = s.write_failed;
  last_why_ = s.why;
  IoStatus status = IoStatus::kNoData;
  if (s.accepted != seen_accepted_) {
    seen_accepted_ = s.accepted;
    last_seq_ = s.seq;
    status = IoStatus::kOk;
  }
  if (s.accepted > 0) {
    // The loop starts every period from an empty frame: the latest values always go in,
    // with the stamps of their requests (so old data ages into the stale cause).
    MergeRouted(config_.inputs, frame, [&s](Input i) {
      return Stamped{s.values[static_cast<std::size_t>(i)], s.stamp_ns};
    });
    // OR, not overwrite: a CAN driver's fault bits may have set it already this period. A
    // fault the current driver reports is the fault line whatever the routing (as on CAN).
    if ((config_.inputs & Bit(Input::kFaultLine)) != 0) {
      frame->fault_line = frame->fault_line || s.fault_line;
    }
    frame->fault_line = frame->fault_line || s.driver_fault;
  }
  if (s.read_failed) {
    *why = s.why;
    return IoStatus::kFault;
  }
  return status;
}

IoStatus ModbusDevice::Write(const IoTime& t, const DriverCommand& cmd, IoError* why) {
  // Lockstep: the published tick's command goes out before a later one replaces it in the
  // one-slot mailbox (only the shutdown's safe block follows a tick without a grant between;
  // otherwise the harness's next grant already came after that command). Bounded wait; in
  // simulated time only.
  const std::uint64_t released = released_tick_.load(std::memory_order_relaxed);  // own write
  if (config_.lockstep && released != 0) {
    // A polling wait: it reads the clock itself (t.wall_ns is the period's start).
    const std::int64_t until = t.wall_ns + kLockstepHandOverNs;
    while (running_.load(std::memory_order_relaxed) &&
           !(handled_any_.load(std::memory_order_acquire) &&
             handled_tick_.load(std::memory_order_acquire) >= released - 1) &&
           common::MonotonicNs() < until) {
      SleepUntil(common::MonotonicNs() + kLockstepIdleNs);
    }
  }
  Command c;
  c.tick = cmd.tick;
  c.volts = cmd.volts;
  c.enable = cmd.enable;
  c.safe = cmd.safe;
  c.echo = last_seq_;
  if (profile_ != nullptr) {
    // The profile's way from E to the set-point; the safe state is not rate-limited.
    if (cmd.safe) command_map_.Reset();
    c.setpoint = command_map_.Apply(cmd.volts, static_cast<double>(config_.period_ns) * 1e-9);
    if (!std::isfinite(cmd.volts)) c.setpoint = cmd.volts;  // refused by the worker: safe
  }
  command_.Write(c);
  // Entering the safe state: the worker writes this block at once (lockstep: PublishStatus).
  if (c.safe && !posted_safe_ && !config_.lockstep) Signal(wake_);
  posted_safe_ = c.safe;
  Sample s;
  if (sample_.TryRead(&s)) {  // the worker's latest word on writes (else: as of Read)
    last_write_failed_ = s.write_failed;
    last_why_ = s.why;
  }
  if (last_write_failed_) {
    *why = last_why_;
    return IoStatus::kFault;
  }
  return IoStatus::kOk;
}

void ModbusDevice::PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) {
  (void)t;
  status_causes_.store(static_cast<std::uint16_t>(stats.active_causes & 0xFFFFU),
                       std::memory_order_relaxed);
  causes_known_.store(true, std::memory_order_relaxed);
  status_ticks_.store(static_cast<std::uint32_t>(stats.ticks & 0xFFFFFFFFU),
                      std::memory_order_relaxed);
  status_model_force_.store(stats.model_force_n, std::memory_order_relaxed);
  status_demand_.store(stats.force_demand_n, std::memory_order_relaxed);
  status_command_.store(stats.last_command_v, std::memory_order_relaxed);
  // Lockstep: the tick's command and status are posted; the worker writes them now.
  if (config_.lockstep) {
    if (command_.version() != 0) {
      released_tick_.store(command_.Read().tick + 1, std::memory_order_release);
    }
    Signal(wake_);
  }
}

bool ModbusDevice::WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) {
  const std::int64_t until = common::MonotonicNs() + timeout_ns;
  while (true) {
    Sample s;
    bool got = false;
    for (int i = 0; i < kReadAttempts && !got; ++i) got = sample_.TryRead(&s);
    if (got && s.grant_ns > granted_ns_) {
      granted_ns_ = s.grant_ns;
      *t_ns = granted_ns_;
      return true;
    }
    const std::int64_t now = common::MonotonicNs();
    if (now >= until) break;
    // The worker signals every new grant; a signal consumed by an earlier call leaves the
    // sample to be seen on the next pass.
    const std::int64_t wait = until - now;
    const timespec ts{static_cast<time_t>(wait / 1'000'000'000),
                      static_cast<long>(wait % 1'000'000'000)};
    pollfd p{grant_event_, POLLIN, 0};
    if (ppoll(&p, 1, &ts, nullptr) > 0) {
      std::uint64_t n = 0;
      (void)!read(grant_event_, &n, sizeof n);
    }
  }
  return false;  // no grant in this slice: the clock keeps waiting (grant_clock.hpp)
}

DeviceCounters ModbusDevice::counters() const {
  DeviceCounters c;
  c.rx_ok = rx_ok_.load(std::memory_order_relaxed);
  c.rx_rejected = rx_rejected_.load(std::memory_order_relaxed);
  c.tx_ok = tx_ok_.load(std::memory_order_relaxed);
  c.tx_failed = tx_failed_.load(std::memory_order_relaxed);
  c.reconnects = reconnects_.load(std::memory_order_relaxed);
  for (std::size_t i = 0; i < kNumIoErrors; ++i) {
    c.errors[i] = errors_[i].load(std::memory_order_relaxed);
  }
  c.last_error = static_cast<IoError>(last_error_.load(std::memory_order_relaxed));
  return c;
}

std::unique_ptr<BusDevice> MakeModbusDevice(const ModbusConfig& config) {
  return std::make_unique<ModbusDevice>(config);
}

}  // namespace mrd::firmware
