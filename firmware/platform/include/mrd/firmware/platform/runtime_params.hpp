#pragma once
// Runtime parameters and reloads: changes are checked off the loop's thread, handed to the
// loop through a one-slot lock-free mailbox and applied at the start of a period (PeriodHook).
//
//   writer (ctl server / reload, one at a time):  idle --Post--> pending
//   loop (BeforePeriod):                          pending --CAS--> taken, apply, --> done
//   writer:                                       done --> idle (reads the period applied)
//   writer on timeout:                            pending --CAS--> idle (nothing applied)
//
// The loop's side is one atomic load per period (two more and a copy when a change is
// pending): no allocation, no lock, no wait. A parameter change retunes the running
// controller (Controller::Retune: model state kept); a reload swaps in a fresh controller
// configured off-thread (model state reset; counted).

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "mrd/common/table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/period_hooks.hpp"
#include "mrd/firmware/platform/config.hpp"

namespace mrd::firmware::platform {

// Why Controller::Configure refused a configuration with this table, in words: the values it
// checks and what they must be, then the fault's name in brackets.
std::string DescribeConfigureRefusal(const ConfigureStatus& s, const CoefficientTable& table,
                                     const ControllerConfig& c);

class RuntimeParams : public PeriodHook {
 public:
  // What a request ended in. kRefused: bad input, nothing changed (exit 2 for the client);
  // kFailed: not applied for another reason (no period ran in time, the loop ended).
  enum class Status : std::uint8_t { kOk = 0, kRefused, kFailed };
  struct Result {
    Status status = Status::kOk;
    std::string message;        // why, when not ok
    std::uint64_t period = 0;   // the period it was applied at (tick number, from 0)
    std::uint32_t version = 0;  // parameter version from that period on
  };
  // Extra checks of a reload's config, table and configured controller (the application's:
  // e.g. the buses serve what the model reads); "" when fine.
  using ReloadCheck =
      std::function<std::string(const FirmwareConfig&, const CoefficientTable&, const Controller&)>;

  // table and config: what the running controller was configured with (config.controller
  // with the effective e_max). Not real-time.
  RuntimeParams(const CoefficientTable& table, const FirmwareConfig& config);

  // Writer side: any non-real-time thread (serialised inside). A request waits up to
  // timeout_ms for the loop to apply it.
  std::vector<ParamInfo> List() const;
  FirmwareConfig config() const;
  Result Set(std::string_view name, std::string_view value, std::int64_t timeout_ms = 5000);
  // Reload to config and table (parsed by the caller): refused when a restart key changed,
  // the table or config does not configure a fresh controller, or check says no; otherwise
  // the fresh controller runs from the next period on.
  Result Reload(const FirmwareConfig& config, const CoefficientTable& table,
                const ReloadCheck& check, std::int64_t timeout_ms = 5000);
  // Set and Reload in two steps, for a single thread that also ticks the loop (tests):
  // PostSet / PostReload check and post (kOk: posted), Finish waits for the loop and commits.
  Result PostSet(std::string_view name, std::string_view value);
  Result PostReload(const FirmwareConfig& config, const CoefficientTable& table,
                    const ReloadCheck& check);
  Result Finish(std::int64_t timeout_ms);
  // The loop has ended: requests fail at once from now on (call after Loop::Run).
  void LoopEnded() { loop_ended_.store(true, std::memory_order_release); }

  std::uint64_t changes() const { return changes_.load(std::memory_order_relaxed); }
  std::uint64_t reloads() const { return reloads_.load(std::memory_order_relaxed); }

  // PeriodHook (the loop's thread). Real-time safe.
  Controller* BeforePeriod(Controller& controller, std::uint64_t period,
                           std::int64_t now_ns) override;
  std::uint32_t version() const override { return version_.load(std::memory_order_relaxed); }

 private:
  enum State : int { kIdle = 0, kPending, kTaken, kDone };
  // Caller holds mu_. PostSetLocked checks a change and posts it; ReloadLocked a reload;
  // WaitLocked waits for the loop and commits next_* (or drops them).
  Result PostSetLocked(std::string_view name, std::string_view value);
  Result PostReloadLocked(const FirmwareConfig& config, const CoefficientTable& table,
                          const ReloadCheck& check);
  Result WaitLocked(std::int64_t timeout_ms);

  mutable std::mutex mu_;  // writers only; the loop never takes it
  CoefficientTable table_;
  FirmwareConfig config_;
  std::unique_ptr<Controller> running_;   // the running controller once a reload made it
  std::unique_ptr<Controller> prepared_;  // a reload's, until the loop has taken it
  FirmwareConfig next_config_;            // what config_ becomes once applied
  CoefficientTable next_table_;
  // The slot: written by the writer while idle, read by the loop while taken.
  ControllerConfig slot_config_;
  Controller* slot_controller_ = nullptr;  // non-null: a reload
  std::atomic<int> state_{kIdle};
  std::atomic<bool> slot_ok_{false};  // the loop applied it (Retune accepted)
  std::atomic<std::uint64_t> slot_period_{0};
  std::atomic<std::uint32_t> version_{0};
  std::atomic<std::uint64_t> changes_{0};
  std::atomic<std::uint64_t> reloads_{0};
  std::atomic<bool> loop_ended_{false};
};

}  // namespace mrd::firmware::platform
