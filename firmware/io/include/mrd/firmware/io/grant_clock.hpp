#pragma once
// Lockstep with a simulator (in the spirit of ArduPilot SITL): the loop's time only advances
// when the harness grants it, so a run is deterministic and as fast as both sides allow.
// The grant travels on the bus that carries the sensors (after the sensor data of that step,
// so a tick that wakes on grant t has the samples of t): a sync frame on CAN, a time register
// on Modbus. The same Loop and controller run; only the Clock differs.
//
//   Now()          = the latest granted time [ns] (0 before the first grant)
//   SleepUntil(t)  = returns at once when Now() >= t; else waits for grants until one is >= t.
//                    Simulated time never depends on wall time: however late a grant comes (a
//                    loaded machine, a harness stopped for a while), the loop waits for it and
//                    no period is inserted. Liveness is separate: when no grant has come for
//                    give_up (wall clock, long: the harness is gone), or the stop flag is set,
//                    the clock halts (Halted() true) and SleepUntil returns; the loop then
//                    ends in the safe state instead of ticking safe periods into a simulation.
//                    The wait is sliced (kSliceNs) so a stop request ends it promptly.

#include <atomic>
#include <cstdint>

#include "mrd/firmware/io.hpp"

namespace mrd::firmware {

// Where grants come from (a bus device that receives them).
class TimeGrantSource {
 public:
  virtual ~TimeGrantSource() = default;
  // Waits at most timeout_ns of wall-clock time for the next grant; true with *t_ns (harness
  // time [ns]). Processes whatever else arrives meanwhile (sensor data). A wait that ends
  // without a grant is not a fault (the clock decides). Bounded: no allocation, one bounded
  // wait.
  virtual bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) = 0;
};

class GrantClock final : public Clock {
 public:
  static constexpr std::int64_t kSliceNs = 50'000'000;  // one WaitGrant call at most [ns]
  // source (and stop, when given) outlive this; give_up_ns > 0 [ns of wall time].
  GrantClock(TimeGrantSource& source, std::int64_t give_up_ns,
             const std::atomic<bool>* stop = nullptr)
      : source_(source), give_up_ns_(give_up_ns), stop_(stop) {}

  std::int64_t Now() override { return now_; }
  void SleepUntil(std::int64_t t_ns) override;
  bool Halted() const override { return halted_; }

  std::uint64_t grants() const { return grants_; }
  // True when the clock halted because no grant came within give_up (not on a stop request).
  bool gave_up() const { return gave_up_; }

 private:
  TimeGrantSource& source_;
  std::int64_t give_up_ns_;
  const std::atomic<bool>* stop_;
  std::int64_t now_ = 0;
  std::uint64_t grants_ = 0;
  bool halted_ = false;
  bool gave_up_ = false;
};

}  // namespace mrd::firmware
