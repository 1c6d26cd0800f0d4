#include "mrd/firmware/platform/runtime_params.hpp"

#include <chrono>
#include <cstdio>
#include <thread>

namespace mrd::firmware::platform {
namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

std::string DescribeConfigureRefusal(const ConfigureStatus& s, const CoefficientTable& table,
                                     const ControllerConfig& c) {
  std::string why = "out of range for the table: ";
  if (s.fault == ConfigureFault::kEMax) {
    why.append("E_max ").append(Num(c.e_max)).append(" V must be above its E_min ");
    why.append(Num(table.e_min)).append(" V and at most its E_max ").append(Num(table.e_max));
    why.append(" V");
  } else if (s.fault == ConfigureFault::kLaw && c.law.mode == ControlMode::kConstantVoltage) {
    why.append("the constant voltage ").append(Num(c.law.constant_voltage));
    why.append(" V must lie in [E_min, E_max] = [").append(Num(table.e_min)).append(", ");
    why.append(Num(c.e_max)).append("] V");
  } else if (s.fault == ConfigureFault::kSafeVoltage) {
    why.append("the safe voltage ").append(Num(c.safe_voltage)).append(" V must lie in its [");
    why.append(Num(table.e_min)).append(", ").append(Num(table.e_max)).append("] V");
  } else if (s.fault != ConfigureFault::kTable) {
    why.append("E_max ").append(Num(c.e_max)).append(" V and the safe voltage ");
    why.append(Num(c.safe_voltage)).append(" V must lie in its [").append(Num(table.e_min));
    why.append(", ").append(Num(table.e_max));
    why.append("] V, a constant voltage in [E_min, E_max]");
  }
  if (s.fault != ConfigureFault::kTable) {
    return why.append(" (").append(ConfigureFaultName(s.fault)).append(")");
  }
  return std::string("the table does not configure a controller: ") + ErrorName(s.error);
}

RuntimeParams::RuntimeParams(const CoefficientTable& table, const FirmwareConfig& config)
    : table_(table), config_(config) {}

std::vector<ParamInfo> RuntimeParams::List() const {
  const std::lock_guard<std::mutex> lock(mu_);
  return ListParams(config_);
}

FirmwareConfig RuntimeParams::config() const {
  const std::lock_guard<std::mutex> lock(mu_);
  return config_;
}

RuntimeParams::Result RuntimeParams::Set(std::string_view name, std::string_view value,
                                         std::int64_t timeout_ms) {
  const std::lock_guard<std::mutex> lock(mu_);
  const Result r = PostSetLocked(name, value);
  return r.status == Status::kOk ? WaitLocked(timeout_ms) : r;
}

RuntimeParams::Result RuntimeParams::PostSet(std::string_view name, std::string_view value) {
  const std::lock_guard<std::mutex> lock(mu_);
  return PostSetLocked(name, value);
}

RuntimeParams::Result RuntimeParams::PostReload(const FirmwareConfig& config,
                                                const CoefficientTable& table,
                                                const ReloadCheck& check) {
  const std::lock_guard<std::mutex> lock(mu_);
  return PostReloadLocked(config, table, check);
}

RuntimeParams::Result RuntimeParams::Finish(std::int64_t timeout_ms) {
  const std::lock_guard<std::mutex> lock(mu_);
  return WaitLocked(timeout_ms);
}

RuntimeParams::Result RuntimeParams::PostSetLocked(std::string_view name, std::string_view value) {
  Result r;
  if (state_.load(std::memory_order_acquire) != kIdle) {
    r.status = Status::kFailed;
    r.message = "another change is pending";
    return r;
  }
  FirmwareConfig next = config_;
  if (!SetParam(&next, name, value, &r.message)) {
    r.status = Status::kRefused;
    return r;
  }
  // The same check as at start-up: a fresh controller on the running table.
  auto probe = std::make_unique<Controller>();
  if (const ConfigureStatus e = probe->Configure(table_, next.controller); !e.ok()) {
    r.status = Status::kRefused;
    r.message = std::string(name) + " = " + std::string(value) + ": " +
                DescribeConfigureRefusal(e, table_, next.controller);
    return r;
  }
  if (loop_ended_.load(std::memory_order_acquire)) {
    r.status = Status::kFailed;
    r.message = "the loop has stopped; nothing changed";
    return r;
  }
  next_config_ = next;
  next_table_ = table_;
  slot_config_ = next.controller;
  slot_controller_ = nullptr;
  state_.store(kPending, std::memory_order_release);
  return r;
}

RuntimeParams::Result RuntimeParams::Reload(const FirmwareConfig& config,
                                            const CoefficientTable& table, const ReloadCheck& check,
                                            std::int64_t timeout_ms) {
  const std::lock_guard<std::mutex> lock(mu_);
  const Result r = PostReloadLocked(config, table, check);
  return r.status == Status::kOk ? WaitLocked(timeout_ms) : r;
}

RuntimeParams::Result RuntimeParams::PostReloadLocked(const FirmwareConfig& config,
                                                      const CoefficientTable& table,
                                                      const ReloadCheck& check) {
  Result r;
  if (state_.load(std::memory_order_acquire) != kIdle) {
    r.status = Status::kFailed;
    r.message = "another change is pending";
    return r;
  }
  r.status = Status::kRefused;
  const std::vector<std::string> restart = RestartKeysChanged(config_, config);
  if (!restart.empty()) {
    r.message = "keys that need a restart changed:";
    for (const std::string& k : restart) r.message += " " + k;
    return r;
  }
  auto fresh = std::make_unique<Controller>();
  if (const ConfigureStatus e = fresh->Configure(table, config.controller); !e.ok()) {
    r.message = DescribeConfigureRefusal(e, table, config.controller);
    return r;
  }
  if (check) {
    r.message = check(config, table, *fresh);
    if (!r.message.empty()) return r;
  }
  if (loop_ended_.load(std::memory_order_acquire)) {
    r.status = Status::kFailed;
    r.message = "the loop has stopped; nothing changed";
    return r;
  }
  prepared_ = std::move(fresh);
  next_config_ = config;
  next_table_ = table;
  slot_config_ = config.controller;
  slot_controller_ = prepared_.get();
  state_.store(kPending, std::memory_order_release);
  r.status = Status::kOk;
  return r;
}

RuntimeParams::Result RuntimeParams::WaitLocked(std::int64_t timeout_ms) {
  Result r;
  if (state_.load(std::memory_order_acquire) == kIdle) {
    r.status = Status::kFailed;
    r.message = "nothing pending";
    return r;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  for (;;) {
    if (state_.load(std::memory_order_acquire) == kDone) break;
    const bool ended = loop_ended_.load(std::memory_order_acquire);
    if (ended || std::chrono::steady_clock::now() > deadline) {
      int expected = kPending;
      if (state_.compare_exchange_strong(expected, kIdle, std::memory_order_acq_rel)) {
        r.status = Status::kFailed;
        r.message = ended ? "the loop has stopped; nothing changed"
                          : "no period ran within " + std::to_string(timeout_ms) +
                                " ms (is the loop waiting for time grants?); nothing changed";
        prepared_.reset();
        return r;
      }
      // The loop has taken it: it finishes within this period.
    }
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  const bool ok = slot_ok_.load(std::memory_order_acquire);
  r.period = slot_period_.load(std::memory_order_acquire);
  r.version = version_.load(std::memory_order_acquire);
  state_.store(kIdle, std::memory_order_release);
  if (!ok) {
    r.status = Status::kRefused;
    r.message = "the controller refused the values; nothing changed";
    prepared_.reset();
    return r;
  }
  config_ = next_config_;
  table_ = next_table_;
  if (prepared_ != nullptr) {
    // A reload: the loop runs the fresh controller now and no longer touches the old one.
    running_ = std::move(prepared_);
  }
  return r;
}

Controller* RuntimeParams::BeforePeriod(Controller& controller, std::uint64_t period,
                                        std::int64_t /*now_ns*/) {
  if (state_.load(std::memory_order_acquire) != kPending) return nullptr;
  int expected = kPending;
  if (!state_.compare_exchange_strong(expected, kTaken, std::memory_order_acq_rel)) {
    return nullptr;  // withdrawn meanwhile
  }
  Controller* next = slot_controller_;
  bool ok = true;
  if (next != nullptr) {
    reloads_.fetch_add(1, std::memory_order_relaxed);
  } else {
    ok = controller.Retune(slot_config_) == Error::kOk;
    if (ok) changes_.fetch_add(1, std::memory_order_relaxed);
  }
  if (ok) version_.fetch_add(1, std::memory_order_relaxed);
  slot_ok_.store(ok, std::memory_order_relaxed);
  slot_period_.store(period, std::memory_order_relaxed);
  state_.store(kDone, std::memory_order_release);
  return next;
}

}  // namespace mrd::firmware::platform
