#pragma once
// The control loop: runs one or more damper channels (channel.hpp: each a SensorSource, a
// CurrentDriver and a Controller) on one clock at a fixed period with absolute deadlines. Per
// period, in order: every channel's period boundary and read (channel order), the body law
// (if any: inputs computed over all channels, e.g. modal skyhook's force demands), clamp dt,
// every channel's update, write and count (channel order), count time. Overruns skip the
// missed deadlines and are counted (in lockstep: a grant that jumps ahead, e.g. to a restarted
// firmware). A clock that halts (the lockstep GrantClock whose harness is gone) ends the run.
// The loop always leaves every driver in the safe state when it returns.
//
// Fault policy between channels (FaultPolicy):
//   kAll      a channel with an active cause of its own in period k puts every other channel
//             safe in period k+1 (their other_channel cause) until it clears: the faulted
//             channel is safe in the period it faults, the others one period later
//   kChannel  channels never affect each other

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "mrd/firmware/channel.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io.hpp"
#include "mrd/firmware/period_hooks.hpp"
#include "mrd/firmware/telemetry.hpp"

namespace mrd::firmware {

inline constexpr std::size_t kMaxChannels = 8;

enum class FaultPolicy : std::uint8_t {
  kAll = 0,  // any channel's fault puts every channel safe (the vehicle default)
  kChannel,  // only the faulted channel goes safe
};

// Inputs computed over all channels after they read and before they update (e.g. modal
// skyhook: each corner's force demand from every corner's body velocity). Real-time safe.
class BodyLaw {
 public:
  virtual ~BodyLaw() = default;
  // frames[i]: channel i's frame as read this period (n channels); sets inputs in them.
  virtual void Apply(SensorFrame* const* frames, std::size_t n, std::int64_t now_ns) = 0;
};

class Loop {
 public:
  // One channel. All references outlive the loop. ok() is false for period_ns <= 0.
  Loop(Clock& clock, SensorSource& source, CurrentDriver& driver, Controller& controller,
       Telemetry& telemetry, std::int64_t period_ns);
  // channels[0..n), each outliving the loop. ok() is false (and the loop holds no channel)
  // for n == 0, n > kMaxChannels, a null channel or period_ns <= 0.
  Loop(Clock& clock, Channel* const* channels, std::size_t n, FaultPolicy policy,
       std::int64_t period_ns);
  Loop(const Loop&) = delete;
  Loop& operator=(const Loop&) = delete;

  // The construction's arguments were valid. A loop that is not ok holds no channel: Run and
  // Tick do nothing, stats() and controller() are an idle channel's; the caller must test it.
  [[nodiscard]] bool ok() const { return count_ != 0; }

  // Runs periods until stop is set or duration_ns has elapsed (<= 0: until stop), then puts
  // the driver in the safe state. Real-time safe after entry (no allocation).
  void Run(const std::atomic<bool>& stop, std::int64_t duration_ns);
  // One period at the loop's time now_ns; the devices' wall time (IoTime) is now_ns on a
  // CLOCK_MONOTONIC clock, else CLOCK_MONOTONIC read once. Real-time safe.
  void Tick(std::int64_t now_ns);
  // One period at the time handed in (t.loop_ns is the loop's time). Real-time safe.
  void Tick(const IoTime& t);
  // Safe state on the driver (shutdown path), at the wall time read now or handed in.
  // Real-time safe.
  void Shutdown();
  void Shutdown(const IoTime& t);

  // Channel 0's counters (with the loop's timing) and controller.
  const TelemetrySnapshot& stats() const;
  const Controller& controller() const;
  std::size_t channel_count() const { return count_; }
  const Channel& channel(std::size_t i) const { return *channels_[i]; }
  // Optional services of channel 0 (period_hooks.hpp); nullptr: none. Set before Run; they
  // outlive the loop. (Channel::SetHook/SetObserver for the others.)
  void SetHook(PeriodHook* hook);
  void SetObserver(PeriodObserver* observer);
  // The body law (nullptr: none). Set before Run; it outlives the loop.
  void SetBodyLaw(BodyLaw* law) { body_law_ = law; }

 private:
  Clock& clock_;
  std::optional<Channel> own_;  // the one-channel constructor's channel
  std::array<Channel*, kMaxChannels> channels_{};
  std::array<SensorFrame*, kMaxChannels> frames_{};
  std::size_t count_ = 0;
  FaultPolicy policy_ = FaultPolicy::kAll;
  std::uint32_t faulted_ = 0;  // bit i: channel i had a cause of its own last period
  BodyLaw* body_law_ = nullptr;
  std::int64_t period_ns_;
  std::int64_t last_tick_ns_ = 0;
  bool first_tick_ = true;
  LoopTiming timing_;
  bool in_run_ = false;  // Run publishes the records after timing the period; a bare Tick at once
};

}  // namespace mrd::firmware
