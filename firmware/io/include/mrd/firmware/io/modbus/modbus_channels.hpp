#pragma once
// Several damper channels on one Modbus link: an RTU line (or a TCP connection) has one
// master, so the channels of a board share one link, one worker thread and one request
// sequence. Each channel has its own device profile (its channel map: sensor block, set-point
// block; modbus_channels.hpp in mrd::profile plans the shared reads) and is handed to the loop
// as its own BusDevice (channel(k): a channel view).
//
// Per cycle the worker writes each channel's latest command (channel 0 first; each channel's
// requests as its one-channel profile writes them, its command last), then reads what all
// channels need (the plan's grouped requests), then publishes one sample holding every
// channel's values. Per channel: its sample, its command (its CommandMap: slew per period),
// its status roles, its fault reset, its counters. A request shared by several channels counts
// its failure for each channel it serves; a decoded value that is not finite fails that
// channel's read alone (bad_value); a connect failure or broken link counts for every channel.
// Timing, retries, reconnects and the backoff are the one-channel device's
// (modbus_device.hpp, docs/modbus_registers.md), as are the start-up and periodic writes
// (every channel's, channel by channel) and the safe block each channel's Deactivate leaves.
//
// Lockstep: the grant is channel 0's grant role, read once per cycle for all channels; channel
// 0's view is the loop's grant source. The worker writes a tick's commands once every channel
// posted its command and status of that tick (at the last channel's PublishStatus), all
// channels in one cycle; a block read before the first grant is no data. What is read and
// written per tick depends on the steps alone, never on when the worker ran.
//
// Views share the device's lifetime: the first view's Configure / Activate configures the
// link and starts the worker, the last view's Deactivate stops it and writes the safe block
// of every channel whose shutdown block the driver has not acknowledged.

#include <pthread.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/io/fault_reset.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/seqlock.hpp"
#include "mrd/profile/command_map.hpp"
#include "mrd/profile/modbus_channels.hpp"

namespace mrd::firmware {

class ModbusLink;

class ModbusChannels final : public TimeGrantSource {
 public:
  static constexpr std::size_t kMaxChannels = profile::kMaxModbusChannels;

  // config: the link ([modbus] keys: mode, endpoint, timeouts, retries, lockstep, inputs,
  // outputs; config.modbus_profile is not used); profiles[k]: channel k's map.
  ModbusChannels(const ModbusConfig& config,
                 std::vector<std::shared_ptr<const profile::ModbusProfile>> profiles);
  ~ModbusChannels() override;
  ModbusChannels(const ModbusChannels&) = delete;
  ModbusChannels& operator=(const ModbusChannels&) = delete;

  // The maps can share the link (PlanModbusChannels; lockstep: channel 0 maps the grant).
  // false: *error; no view may be used then.
  bool ok(std::string* error) const;
  std::size_t size() const { return n_; }
  BusDevice& channel(std::size_t k);
  const profile::ModbusChannelPlan& plan() const { return plan_; }

  bool WaitGrant(std::int64_t timeout_ns, std::int64_t* t_ns) override;

 private:
  class View;
  class Waker;

  struct ChannelSample {
    std::uint64_t accepted = 0;  // sensor blocks accepted so far (changes: new data)
    std::int64_t stamp_ns = 0;   // the cycle's first request (lockstep: the grant)
    std::uint32_t seq = 0;
    std::array<double, kNumInputs> values{};
    bool fault_line = false;
    bool driver_fault = false;
    bool read_failed = false;
    bool write_failed = false;
    IoError why = IoError::kNone;
  };
  struct Sample {
    std::int64_t grant_ns = 0;  // lockstep: the latest granted time (0: none yet)
    std::array<ChannelSample, kMaxChannels> ch{};
  };
  struct Command {
    std::uint64_t tick = 0;
    double setpoint = 0.0;  // after the channel's CommandMap (driver's unit)
    bool enable = false;
    bool safe = true;
    std::uint32_t echo = 0;
  };
  struct Counters {
    std::atomic<std::uint64_t> rx_ok{0}, rx_rejected{0}, tx_ok{0}, tx_failed{0}, reconnects{0};
    std::atomic<std::uint64_t> errors[kNumIoErrors] = {};
    std::atomic<std::uint8_t> last_error{0};
  };
  // One channel: its map and the state of both sides.
  struct Channel {
    const profile::ModbusProfile* profile = nullptr;
    Seqlock<Command> command;
    Counters counters;
    std::atomic<std::uint16_t> status_causes{0};
    std::atomic<bool> causes_known{false};
    std::atomic<double> status_model_force{0.0}, status_demand{0.0}, status_command{0.0};
    // Worker side.
    bool have_seq = false;
    bool any_written = false;
    std::uint64_t written_tick = 0;
    bool written_safe = true;
    bool safe_acknowledged = false;
    std::uint64_t safe_acknowledged_tick = 0;
    bool driver_fault_seen = false;
    FaultResetRule reset_rule;
    // Loop side (tick thread only).
    profile::CommandMap command_map;
    double safe_setpoint = 0.0;
    ChannelSample cached;
    std::uint64_t seen_accepted = 0;
    std::uint32_t last_seq = 0;
    bool last_write_failed = false;
    IoError last_why = IoError::kNone;
    bool posted_safe = true;
    std::uint64_t published = 0;  // lockstep: one past the tick of its last PublishStatus
  };
  enum class Outcome : std::uint8_t { kOk, kFailed, kAbandoned, kNothing };
  enum class CycleEnd : std::uint8_t { kDone, kNoSession, kSessionEnded, kAbandoned };

  // View lifetime (the first configures / starts, the last stops).
  bool Configure(std::string* error);
  bool Activate(std::string* error);
  void Deactivate();

  // Loop side, channel k (modbus_device_channel_view.cpp).
  IoStatus Read(std::size_t k, SensorFrame* frame, IoError* why);
  IoStatus Write(std::size_t k, const IoTime& t, const DriverCommand& cmd, IoError* why);
  void PublishStatus(std::size_t k, const TelemetrySnapshot& stats);
  DeviceCounters counters(std::size_t k) const;

  // Worker (modbus_device_channels.cpp).
  static void* WorkerMain(void* self);
  void WorkPolling();
  void WorkLockstep();
  CycleEnd Cycle(Sample* s, int* timed_out_cycles, bool* new_grant);
  bool Connect(Sample* s);
  void EndSession();
  Outcome WriteAll(Sample* s);
  Outcome WriteChannel(std::size_t k, const Command& c, IoError* why, bool interruptible);
  Outcome ReadAll(Sample* s, bool* new_grant);
  void Decode(std::size_t k, const double* values, std::int64_t stamp, Sample* s);
  bool StartUpWrites(Sample* s);
  void PeriodicWrites(Sample* s);
  bool WriteFixed(const profile::ModbusFixedWrite& w, std::uint32_t mask, IoError* why,
                  std::uint8_t* exception);
  bool SafePending() const;
  // Counts a failed attempt for the channels of mask (reply_refused: rx_rejected too).
  void Failed(IoError e, bool reply_refused, std::uint32_t mask);
  void GoodExchange();
  void FailAll(Sample* s, std::uint32_t mask, bool reads, bool writes, IoError why);

  ModbusConfig config_;
  std::vector<std::shared_ptr<const profile::ModbusProfile>> profiles_;
  std::size_t n_ = 0;
  std::uint32_t all_ = 0;  // bit k for every channel
  profile::ModbusChannelPlan plan_;
  std::string error_;  // why the maps cannot share the link (empty: they can)
  std::array<Channel, kMaxChannels> ch_;
  std::vector<std::unique_ptr<View>> views_;
  std::unique_ptr<std::uint16_t[]> words_;        // worker: one write request's words
  std::unique_ptr<std::uint8_t[]> replies_;       // worker: every read's reply (kMaxPdu each)
  std::unique_ptr<std::int64_t[]> periodic_due_;  // worker: next time of each periodic write
  std::vector<const profile::ModbusFixedWrite*> startup_, periodic_;  // every channel's
  std::vector<std::uint32_t> startup_mask_, periodic_mask_;           // whose they are
  std::unique_ptr<ModbusLink> link_;
  std::unique_ptr<Waker> waker_;
  int configured_views_ = 0, active_views_ = 0;
  bool configured_ = false;
  pthread_t thread_{};
  bool thread_started_ = false;
  std::atomic<bool> running_{false};
  int wake_ = -1;
  int grant_event_ = -1;
  Seqlock<Sample> sample_;
  std::atomic<int> startup_refused_{0};  // index + 1 into startup_ (0: none)
  std::atomic<std::uint8_t> startup_exception_{0};

  // Worker side.
  bool started_ = false;
  std::array<std::int64_t, kMaxChannels> decoded_grant_{};  // lockstep: the step each decoded
  bool resync_ = false;
  std::int64_t unanswered_since_ns_ = 0;
  bool timed_out_ = false;
  bool writing_safe_ = false;
  std::int64_t backoff_ns_ = 0;
  std::int64_t connect_at_ns_ = 0;
  bool ever_connected_ = false;

  // Lockstep: the tick all channels published (one past it; loop writes, worker reads) and
  // the last tick the worker wrote (or failed to write) for every channel.
  std::atomic<std::uint64_t> released_tick_{0};
  std::atomic<std::uint64_t> handled_tick_{0};
  std::atomic<bool> handled_any_{false};
  std::int64_t granted_ns_ = 0;
};

}  // namespace mrd::firmware
