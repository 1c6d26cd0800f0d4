#pragma once
// Lockstep with a simulator (in the spirit of ArduPilot SITL): the loop's time only advances
// when the harness grants it, so a run is deterministic and as fast as both sides allow.
// The grant travels on the bus that carries the sensors (after the sensor data of that step,
// so a tick that wakes on grant t has the samples of t): a sync frame on CAN, a time register
// on Modbus. The same Loop and controller run; only the Clock differs.
//
//   Now()          = the latest granted time [ns] (0 before the first grant)
//   SleepUntil(t)  = returns at once when Now() >= t; else waits for grants until one is >= t.
//                    A grant that does not come within grant_timeout (wall clock) is a fault,
//                    not a hang: SleepUntil returns without one (time stays at the last grant:
//                    only the harness moves time) and counts a missed grant; the device reports
//                    the period as a bus timeout, so the loop commands the safe state. The loop
//                    then re-aligns its next deadline on Now() (loop.hpp), so the next grant
//                    ticks it again: a lost grant or command costs one safe period, never a
//                    permanent offset between harness and firmware.
//                    Before the first grant the wait is first_grant_timeout (start-up: the
//                    harness may come up after the firmware); a miss there is counted the same.

#include <cstdint>

#include "mrd/firmware/io.hpp"

namespace mrd::firmware {

// Where grants come from (a bus device that receives them).
class TimeGrantSource {
 public:
  virtual ~TimeGrantSource() = default;
  // Waits at most timeout_ns of wall-clock time for the next grant; true with *t_ns (harness
  // time [ns]). Processes whatever else arrives meanwhile (sensor data). Real-time safe in the
  // sense of bounded: no allocation, one bounded wait.
  virtual bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) = 0;
};

class GrantClock final : public Clock {
 public:
  // source outlives this; grant_timeout_ns > 0.
  static constexpr std::int64_t kFirstGrantTimeoutNs = 5'000'000'000;
  GrantClock(TimeGrantSource& source, std::int64_t grant_timeout_ns,
             std::int64_t first_grant_timeout_ns = kFirstGrantTimeoutNs)
      : source_(source),
        timeout_ns_(grant_timeout_ns),
        first_timeout_ns_(first_grant_timeout_ns > grant_timeout_ns ? first_grant_timeout_ns
                                                                    : grant_timeout_ns) {}

  std::int64_t Now() override { return now_; }
  void SleepUntil(std::int64_t t_ns) override;

  std::uint64_t grants() const { return grants_; }
  std::uint64_t missed_grants() const { return missed_; }

 private:
  TimeGrantSource& source_;
  std::int64_t timeout_ns_;
  std::int64_t first_timeout_ns_;
  std::int64_t now_ = 0;
  std::uint64_t grants_ = 0;
  std::uint64_t missed_ = 0;
};

}  // namespace mrd::firmware
