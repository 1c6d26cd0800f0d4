#include "mrd/firmware/io/modbus_device.hpp"

#include <modbus/modbus.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <memory>

#include "mrd/firmware/io/devices.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "mrd/protocol/modbus_map.hpp"

namespace mrd::firmware {
namespace {

namespace map = mrd::protocol::modbus;

constexpr int kMaxFailedCycles = 3;  // then close and reconnect
constexpr std::int64_t kBackoffMinNs = 5'000'000;
constexpr std::int64_t kBackoffMaxNs = 200'000'000;
constexpr std::int64_t kSleepSliceNs = 5'000'000;  // Deactivate waits at most this long
constexpr int kReadAttempts = 4;                   // seqlock attempts per Read on the tick
constexpr int kMaxResyncRounds = 4;  // quiet-line waits after a failed exchange, at most

constexpr std::int64_t kLockstepIdleNs = 20'000;             // between reads without a new grant
constexpr std::int64_t kLockstepCommandWaitNs = 100'000'000;  // for the tick's command

std::int64_t NowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void SleepUntil(std::int64_t t_ns) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t_ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(t_ns % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// eventfd wake-ups (lockstep). Signal never blocks (a full counter is already a wake-up).
void Signal(int fd) {
  const std::uint64_t one = 1;
  (void)!write(fd, &one, sizeof one);
}
// Waits for fd's signal (consumed) at most timeout_ns, in slices so a stop request is seen.
bool WaitEvent(int fd, std::int64_t timeout_ns, const std::atomic<bool>& running) {
  const std::int64_t until = NowNs() + timeout_ns;
  for (std::int64_t now = NowNs(); now < until && running.load(std::memory_order_relaxed);
       now = NowNs()) {
    const std::int64_t wait = until - now < kSleepSliceNs ? until - now : kSleepSliceNs;
    const timespec ts{static_cast<time_t>(wait / 1'000'000'000), static_cast<long>(wait % 1'000'000'000)};
    pollfd p{fd, POLLIN, 0};
    if (ppoll(&p, 1, &ts, nullptr) > 0) {
      std::uint64_t n = 0;
      (void)!read(fd, &n, sizeof n);
      return true;
    }
  }
  return false;
}

// libmodbus errno -> why.
IoError Classify(int err) {
  if (err == ETIMEDOUT) return IoError::kTimeout;
  if (err == EMBBADCRC) return IoError::kCrc;
  if (err >= EMBXILFUN && err <= EMBXGTAR) return IoError::kException;
  if (err == EMBBADDATA || err == EMBBADEXC || err == EMBUNKEXC || err == EMBMDATA ||
      err == EMBBADSLAVE) {
    return IoError::kRejectedFrame;
  }
  if (err == ECONNRESET || err == EPIPE || err == ECONNREFUSED || err == ENOTCONN || err == EBADF ||
      err == EIO || err == ENXIO || err == ENOENT || err == EHOSTUNREACH || err == ENETUNREACH ||
      err == ECONNABORTED) {
    return IoError::kDisconnected;
  }
  return IoError::kSystem;
}

bool Retriable(IoError e) { return e == IoError::kTimeout || e == IoError::kCrc; }

void SetTimeout(modbus_t* ctx, std::int64_t ns) {
  const auto sec = static_cast<std::uint32_t>(ns / 1'000'000'000);
  const auto usec = static_cast<std::uint32_t>((ns % 1'000'000'000) / 1000);
  modbus_set_response_timeout(ctx, sec, usec);
  modbus_set_byte_timeout(ctx, sec, usec);
}

}  // namespace

ModbusDevice::ModbusDevice(const ModbusConfig& config) : config_(config) {}

ModbusDevice::~ModbusDevice() {
  Deactivate();
  if (ctx_ != nullptr) modbus_free(ctx_);
  if (grant_event_ >= 0) close(grant_event_);
  if (command_event_ >= 0) close(command_event_);
}

bool ModbusDevice::Configure(std::string* error) {
  if (ctx_ != nullptr) return true;
  if (config_.lockstep && grant_event_ < 0) {
    grant_event_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    command_event_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (grant_event_ < 0 || command_event_ < 0) {
      *error = std::string("modbus: eventfd: ") + std::strerror(errno);
      return false;
    }
  }
  if (config_.mode == ModbusMode::kTcp) {
    const std::string port = std::to_string(config_.port);
    ctx_ = modbus_new_tcp_pi(config_.host.c_str(), port.c_str());
  } else {
    ctx_ = modbus_new_rtu(config_.device.c_str(), config_.baud, config_.parity, config_.data_bits,
                          config_.stop_bits);
  }
  if (ctx_ == nullptr) {
    *error = std::string("modbus: cannot create the ") +
             (config_.mode == ModbusMode::kTcp ? "TCP" : "RTU") +
             " context: " + modbus_strerror(errno);
    return false;
  }
  if (modbus_set_slave(ctx_, config_.slave) != 0) {
    *error = std::string("modbus: slave ") + std::to_string(config_.slave) + ": " +
             modbus_strerror(errno);
    return false;
  }
  SetTimeout(ctx_, config_.response_timeout_ns);
  if (!Connect()) {
    const std::string where = config_.mode == ModbusMode::kTcp
                                  ? config_.host + ":" + std::to_string(config_.port)
                                  : config_.device;
    std::fprintf(stderr,
                 "warning: modbus: cannot connect to %s yet (%s); retrying in the "
                 "background, the loop stays in the safe state until data arrives\n",
                 where.c_str(), modbus_strerror(errno));
  }
  return true;
}

bool ModbusDevice::Activate(std::string* error) {
  if (thread_started_) return true;
  if (ctx_ == nullptr && !Configure(error)) return false;
  running_.store(true);
  const int rc = pthread_create(&thread_, nullptr, &ModbusDevice::WorkerMain, this);
  if (rc != 0) {
    running_.store(false);
    *error = std::string("modbus: cannot start the I/O thread: ") + std::strerror(rc);
    return false;
  }
  thread_started_ = true;
  return true;
}

void ModbusDevice::Deactivate() {
  if (thread_started_) {
    running_.store(false);
    pthread_join(thread_, nullptr);
    thread_started_ = false;
  }
  if (ctx_ == nullptr) return;
  if (connected_ && (config_.outputs & (Bit(Output::kCommand) | Bit(Output::kEnable))) != 0) {
    Command safe;
    safe.tick = command_.Read().tick + 1;
    safe.echo = last_seq_;
    IoError why = IoError::kNone;
    (void)WriteCommand(safe, &why);  // best effort: the peer may be gone
  }
  Disconnect();
}

void* ModbusDevice::WorkerMain(void* self) {
  static_cast<ModbusDevice*>(self)->Work();
  return nullptr;
}

bool ModbusDevice::Connect() {
  if (modbus_connect(ctx_) != 0) {
    connected_ = false;
    return false;
  }
  connected_ = true;
  if (ever_connected_) reconnects_.fetch_add(1, std::memory_order_relaxed);
  ever_connected_ = true;
  resync_ = false;
  modbus_flush(ctx_);
  return true;
}

void ModbusDevice::Disconnect() {
  if (connected_) modbus_close(ctx_);
  connected_ = false;
}

void ModbusDevice::Resync() {
  // A failed exchange may leave a reply on its way: the peer answered after the timeout, or
  // the rest of a frame torn by a stall. RTU has no transaction id, so that late reply would
  // be taken as the answer to the next request, and each reply after it refused as the wrong
  // one: one late peer became a run of refused frames. Discard input until the line has been
  // quiet for one response timeout (at most kMaxResyncRounds waits; worker thread only),
  // before the next request: the failure itself is reported at once.
  resync_ = false;
  const int fd = modbus_get_socket(ctx_);
  const std::int64_t quiet = config_.response_timeout_ns;
  const timespec ts{static_cast<time_t>(quiet / 1'000'000'000),
                    static_cast<long>(quiet % 1'000'000'000)};
  for (int round = 0; round < kMaxResyncRounds; ++round) {
    modbus_flush(ctx_);
    if (fd < 0 || !running_.load(std::memory_order_relaxed)) return;
    pollfd p{fd, POLLIN, 0};
    if (ppoll(&p, 1, &ts, nullptr) <= 0) return;  // quiet (or an error the next request sees)
  }
  modbus_flush(ctx_);
}

void ModbusDevice::Count(IoError e) {
  errors_[static_cast<std::size_t>(e)].fetch_add(1, std::memory_order_relaxed);
  last_error_.store(static_cast<std::uint8_t>(e), std::memory_order_relaxed);
}

bool ModbusDevice::ReadSensors(std::uint16_t* regs, int count, IoError* why) {
  for (int attempt = 0; attempt <= config_.retries; ++attempt) {
    if (resync_) Resync();
    if (modbus_read_registers(ctx_, map::kSensorBase, count, regs) == count) {
      return true;
    }
    *why = Classify(errno);
    Count(*why);
    if (*why != IoError::kTimeout && *why != IoError::kDisconnected) {
      rx_rejected_.fetch_add(1, std::memory_order_relaxed);  // a reply came and was refused
    }
    resync_ = *why != IoError::kDisconnected;
    if (!Retriable(*why)) return false;
  }
  return false;
}

bool ModbusDevice::WriteCommand(const Command& c, IoError* why) {
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
  std::uint16_t regs[map::kCommandCount] = {};
  if (map::EncodeCommand(b, regs) != map::MapError::kOk) {
    *why = IoError::kBadValue;  // a set-point outside the register's range is not sent
    Count(*why);
    tx_failed_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  for (int attempt = 0; attempt <= config_.retries; ++attempt) {
    if (resync_) Resync();
    if (modbus_write_registers(ctx_, map::kCommandBase, map::kCommandCount, regs) ==
        map::kCommandCount) {
      tx_ok_.fetch_add(1, std::memory_order_relaxed);
      return true;
    }
    *why = Classify(errno);
    Count(*why);
    resync_ = *why != IoError::kDisconnected;
    if (!Retriable(*why)) break;
  }
  tx_failed_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

void ModbusDevice::Work() {
  const bool reads = config_.inputs != 0;
  const bool writes = config_.outputs != 0;
  Sample s;  // the worker's copy of what it publishes
  std::uint64_t written_tick = 0;
  bool any_written = false;
  bool have_seq = false;
  int failed_cycles = 0;
  std::int64_t backoff_ns = kBackoffMinNs;
  std::int64_t next = NowNs();
  while (running_.load(std::memory_order_relaxed)) {
    if (!connected_) {
      if (!Connect()) {
        Count(IoError::kDisconnected);
        s.read_failed = reads;
        s.write_failed = writes;
        s.why = IoError::kDisconnected;
        sample_.Write(s);
        const std::int64_t until = NowNs() + backoff_ns;
        backoff_ns = backoff_ns * 2 > kBackoffMaxNs ? kBackoffMaxNs : backoff_ns * 2;
        for (std::int64_t t = NowNs(); t < until && running_.load(std::memory_order_relaxed);
             t = NowNs()) {
          SleepUntil(t + kSleepSliceNs < until ? t + kSleepSliceNs : until);
        }
        next = NowNs();
        continue;
      }
      backoff_ns = kBackoffMinNs;
      failed_cycles = 0;
      have_seq = false;  // a new peer may restart its sequence
    }

    bool cycle_failed = false;
    IoError why = IoError::kNone;
    if (writes) {
      Command c;
      if (command_.TryRead(&c) && command_.version() > 0 &&
          (!any_written || c.tick != written_tick)) {
        // Sent or failed (after retries), a command is not sent again: the loop's next
        // one supersedes it.
        s.write_failed = !WriteCommand(c, &why);
        written_tick = c.tick;
        any_written = true;
        if (s.write_failed) {
          cycle_failed = true;
          s.why = why;
        }
      }
    }
    bool new_grant = false;
    if ((reads || config_.lockstep) && connected_ && why != IoError::kDisconnected) {
      std::uint16_t regs[map::kLockstepSensorCount] = {};
      IoError rwhy = IoError::kNone;
      const int count = config_.lockstep ? map::kLockstepSensorCount : map::kSensorCount;
      if (ReadSensors(regs, count, &rwhy)) {
        std::int64_t stamp = NowNs();
        if (config_.lockstep) {
          // The grant follows its step's sensor values: they are stamped with it.
          const auto grant = static_cast<std::int64_t>(map::GetU48(regs + map::kGrant)) * 1000;
          new_grant = grant > s.grant_ns;
          if (new_grant) s.grant_ns = grant;
          stamp = s.grant_ns;
        }
        map::SensorBlock b;
        if (map::DecodeSensors(regs, &b) != map::MapError::kOk) {
          rwhy = IoError::kBadValue;
          Count(rwhy);
          rx_rejected_.fetch_add(1, std::memory_order_relaxed);
          s.read_failed = true;
          s.why = rwhy;
          cycle_failed = true;
        } else {
          s.read_failed = false;
          if (!have_seq || b.seq != s.seq) {  // a repeated seq is not new data
            have_seq = true;
            s.seq = b.seq;
            s.stamp_ns = stamp;
            s.velocity = b.velocity;
            s.displacement = b.displacement;
            s.demand = b.demand;
            s.body_velocity = b.body_velocity;
            s.force = b.force;
            s.fault_line = b.fault_line || b.driver_fault;
            ++s.accepted;
            rx_ok_.fetch_add(1, std::memory_order_relaxed);
          }
        }
      } else {
        s.read_failed = true;
        s.why = rwhy;
        why = rwhy;
        cycle_failed = true;
      }
    }
    if (!s.read_failed && !s.write_failed) s.why = IoError::kNone;
    sample_.Write(s);

    failed_cycles = cycle_failed ? failed_cycles + 1 : 0;
    if (why == IoError::kDisconnected || failed_cycles >= kMaxFailedCycles) {
      Disconnect();
      failed_cycles = 0;
      continue;
    }
    if (config_.lockstep) {
      // A new grant: wake the loop, wait for its tick's command (written at the top of the
      // next cycle). Else read again soon: the harness sets the next grant after our command.
      if (new_grant) {
        Signal(grant_event_);
        WaitEvent(command_event_, kLockstepCommandWaitNs, running_);
      } else {
        SleepUntil(NowNs() + kLockstepIdleNs);
      }
      continue;
    }
    next += config_.poll_period_ns;
    const std::int64_t now = NowNs();
    if (next < now) next = now;  // behind (slow peer): no catch-up burst
    SleepUntil(next);
  }
}

IoStatus ModbusDevice::Read(SensorFrame* frame, IoError* why) {
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
    // with the stamps of when they arrived (so old data ages into the stale cause).
    const std::uint32_t in = config_.inputs;
    if ((in & Bit(Input::kVelocity)) != 0) frame->velocity = {s.velocity, s.stamp_ns};
    if ((in & Bit(Input::kDisplacement)) != 0) frame->displacement = {s.displacement, s.stamp_ns};
    if ((in & Bit(Input::kDemand)) != 0) frame->demand = {s.demand, s.stamp_ns};
    if ((in & Bit(Input::kBodyVelocity)) != 0) frame->body_velocity = {s.body_velocity, s.stamp_ns};
    if ((in & Bit(Input::kForce)) != 0) frame->force = {s.force, s.stamp_ns};
    if ((in & Bit(Input::kFaultLine)) != 0) frame->fault_line = s.fault_line;
  }
  if (s.read_failed) {
    *why = s.why;
    return IoStatus::kFault;
  }
  return status;
}

IoStatus ModbusDevice::Write(const DriverCommand& cmd, IoError* why) {
  Command c;
  c.tick = cmd.tick;
  c.volts = cmd.volts;
  c.enable = cmd.enable;
  c.safe = cmd.safe;
  c.echo = last_seq_;
  command_.Write(c);
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

void ModbusDevice::PublishStatus(const TelemetrySnapshot& stats) {
  status_causes_.store(static_cast<std::uint16_t>(stats.active_causes & 0xFFFFU),
                       std::memory_order_relaxed);
  status_ticks_.store(static_cast<std::uint32_t>(stats.ticks & 0xFFFFFFFFU),
                      std::memory_order_relaxed);
  // Lockstep: the tick's command and status are posted; the worker writes them now.
  if (config_.lockstep) Signal(command_event_);
}

bool ModbusDevice::WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) {
  const std::int64_t until = NowNs() + timeout_ns;
  while (true) {
    Sample s;
    bool got = false;
    for (int i = 0; i < kReadAttempts && !got; ++i) got = sample_.TryRead(&s);
    if (got && s.grant_ns > granted_ns_) {
      granted_ns_ = s.grant_ns;
      *t_ns = granted_ns_;
      return true;
    }
    const std::int64_t now = NowNs();
    if (now >= until) break;
    // The worker signals every new grant; a signal consumed by an earlier call leaves the
    // sample to be seen on the next pass.
    const std::int64_t wait = until - now;
    const timespec ts{static_cast<time_t>(wait / 1'000'000'000), static_cast<long>(wait % 1'000'000'000)};
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
