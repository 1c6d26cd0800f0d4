#pragma once
// What the loop hands out and takes in at each period, for the services around it (the
// per-period log, runtime parameters, reload). Both hooks run on the loop's thread and must be
// real-time safe: no allocation, no blocking, no exceptions.
//
//   PeriodHook::BeforePeriod   at the start of a period, before the inputs are read: applies a
//                              pending parameter change or reload (a period boundary)
//   PeriodObserver::OnPeriod   after the period's work and its timing are known: the record

#include <cstdint>

#include "mrd/firmware/io.hpp"

namespace mrd::firmware {

class Controller;

// One period as the loop saw it. Inputs are as received (NaN and age -1 when never sampled);
// "used" values are what the model ran on (last valid, held to the table's envelope).
struct PeriodRecord {
  std::uint64_t period = 0;     // tick number, from 0
  std::int64_t t_ns = 0;        // period time (loop clock) [ns]
  std::int64_t latency_ns = 0;  // wake-up minus deadline [ns] (0 for a bare Tick)
  std::int64_t exec_ns = 0;     // work of this period [ns] (0 for a bare Tick)
  SensorFrame frame;            // inputs as received (values and stamps)
  IoStatus read = IoStatus::kOk;
  IoStatus write = IoStatus::kOk;
  double v_used = 0.0;        // [cm/s]
  double x_used = 0.0;        // [cm]
  double model_force = 0.0;   // [N]
  double force_demand = 0.0;  // [N] (0 for a voltage law)
  double e_law = 0.0;         // the law's command before clamping/safe state: the
                              // inverse at the demand (force laws) or the law's voltage
                              // [V]; NaN in the safe state (Controller::law_volts)
  double command_v = 0.0;     // command written [V] (safe voltage when safe)
  bool force_law = false;
  bool reachable = true;
  bool passive = false;       // force law: demand 0 or of the sign opposite to v (E_min)
  bool non_monotone = false;  // force law: the model not monotone in E at the state
  bool safe = true;
  std::uint32_t causes = 0;         // watchdog causes (Watchdog::Bit)
  std::uint32_t param_version = 0;  // bumped by every applied parameter change or reload
};

class PeriodHook {
 public:
  virtual ~PeriodHook() = default;
  // Start of period `period` (tick number, from 0) at now_ns: applies what is pending to the
  // controller. Returns the controller to run from this period on (a reload: a fresh one,
  // prepared off the loop's thread, model state reset), or nullptr to keep `controller`.
  // Real-time safe.
  virtual Controller* BeforePeriod(Controller& controller, std::uint64_t period,
                                   std::int64_t now_ns) = 0;
  // Applied changes so far (PeriodRecord::param_version).
  virtual std::uint32_t version() const = 0;
};

class PeriodObserver {
 public:
  virtual ~PeriodObserver() = default;
  // The period's record. Real-time safe; must not block (drop and count instead).
  virtual void OnPeriod(const PeriodRecord& record) = 0;
};

}  // namespace mrd::firmware
