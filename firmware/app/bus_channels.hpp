#pragma once
// Several damper channels over one bus ([channels] count > 1 with [can] and can_profiles, or
// with [modbus] and modbus_profiles): each channel has its own device (channel_devices.hpp: a
// CAN device with its profile on its own socket of the one bus, or its view of the one Modbus
// link with its register map), its FieldbusIo, controller (its table of [channels] tables, one
// model per distinct table: channel_models.hpp), watchdog, counters and telemetry; all on one
// loop under the config's fault policy and body law. Channel 0's device is, in lockstep
// ([loop] clock = "grant"), the loop's grant source (CAN: the others' devices follow, each
// Read waiting for its own socket to deliver the tick's grant; Modbus: one grant register read
// once per cycle for all). The caller runs the loop (main.cpp's real-time thread); the
// per-period log records channel 0; runtime parameters and reloads are not applied (the config
// refuses [ctl] with several channels).

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mrd/common/table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/modal_body_law.hpp"
#include "mrd/firmware/modal_skyhook.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/firmware/telemetry.hpp"
#include "summary_json.hpp"

namespace mrd::firmware {

struct BusChannelsRun {
  const platform::FirmwareConfig& cfg;
  const char* config_path;                 // for the error messages
  const mrd::CoefficientTable& run_table;  // channels without a table of their own
  const char* run_table_name;
  bool allow_demo_table;          // --allow-demo-table
  const std::atomic<bool>* stop;  // ends the grant clock's wait (lockstep)
};

class BusChannels {
 public:
  // first: channel 0's telemetry (the summary's top-level figures); outlives this.
  BusChannels(const BusChannelsRun& run, Telemetry* first);
  ~BusChannels();  // every device deactivated (its last word: the safe command)
  BusChannels(const BusChannels&) = delete;
  BusChannels& operator=(const BusChannels&) = delete;

  // Start-up (allocates): the models and controllers, a device per channel configured and
  // activated in channel order (CANopen: each its drive's SDO list and NMT start; Modbus: the
  // first starts the link), the clock
  // and the loop. -1 (ready), or the exit status with the reason on stderr: 2 a refused table
  // or configuration, 1 a device that does not start.
  int Start();
  Loop& loop() { return *loop_; }
  // Lockstep: the grant clock (its figures after the run); else nullptr.
  const GrantClock* grant_clock() const { return grant_clock_ ? &*grant_clock_ : nullptr; }

  // After the run: every device deactivated and handed over (the summary's "devices"), their
  // faulted periods, each channel's table, counters and device.
  void Finish(std::vector<std::unique_ptr<BusDevice>>* devices, std::vector<DeviceFaults>* faults,
              std::vector<SummaryInfo::Channel>* channels);

 private:
  struct Corner;
  std::string MakeCorners();

  BusChannelsRun run_;
  Telemetry* first_;
  std::vector<Telemetry> rest_;
  std::vector<std::unique_ptr<Corner>> corners_;
  MonotonicClock monotonic_;
  std::optional<GrantClock> grant_clock_;
  ModalSkyhook skyhook_;
  ModalBodyLaw body_law_{skyhook_};
  std::optional<Loop> loop_;
};

}  // namespace mrd::firmware
