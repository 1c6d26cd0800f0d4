#include "channel_devices.hpp"

#include "mrd/firmware/io/devices.hpp"
#include "mrd/firmware/io/modbus/modbus_channels.hpp"

namespace mrd::firmware {
namespace {

// The devices' names in the summary: channel 0's is the one-channel name.
constexpr const char* kCanNames[kMaxChannels] = {"can",  "can1", "can2", "can3",
                                                 "can4", "can5", "can6", "can7"};
constexpr const char* kModbusNames[kMaxChannels] = {"modbus",  "modbus1", "modbus2", "modbus3",
                                                    "modbus4", "modbus5", "modbus6", "modbus7"};

// Channel k's view of the shared link, owning a share of it: the loop and the summary see a
// device per channel; the link (and its worker) goes with the last of them.
class LinkChannel final : public BusDevice {
 public:
  LinkChannel(std::shared_ptr<ModbusChannels> link, std::size_t k)
      : link_(std::move(link)), view_(link_->channel(k)), name_(kModbusNames[k]) {}
  const char* name() const override { return name_; }
  FaultCause fault_cause() const override { return view_.fault_cause(); }
  bool write_faults_are_bus_faults() const override { return view_.write_faults_are_bus_faults(); }
  bool Configure(std::string* error) override { return view_.Configure(error); }
  bool Activate(std::string* error) override { return view_.Activate(error); }
  void Deactivate() override { view_.Deactivate(); }
  IoStatus Read(const IoTime& t, SensorFrame* frame, IoError* why) override {
    return view_.Read(t, frame, why);
  }
  IoStatus Write(const IoTime& t, const DriverCommand& cmd, IoError* why) override {
    return view_.Write(t, cmd, why);
  }
  void PublishStatus(const IoTime& t, const TelemetrySnapshot& stats) override {
    view_.PublishStatus(t, stats);
  }
  DeviceCounters counters() const override { return view_.counters(); }
  TimeGrantSource* grant_source() override { return view_.grant_source(); }

 private:
  std::shared_ptr<ModbusChannels> link_;
  BusDevice& view_;
  const char* name_;
};

std::string MakeCanChannels(const platform::FirmwareConfig& cfg, const std::atomic<bool>* stop,
                            std::vector<std::unique_ptr<BusDevice>>* out) {
  const bool grant = cfg.clock == platform::LoopClock::kGrant;
  for (std::size_t i = 0; i < cfg.channels.can_device_profiles.size(); ++i) {
    CanConfig can = cfg.io.can;
    can.can_profile = cfg.channels.can_device_profiles[i];
    can.profile = cfg.channels.can_profiles[i];
    can.name = kCanNames[i];
    can.node_frames = i == 0;              // one node, one heartbeat (and SYNC)
    can.grant_follower = grant && i != 0;  // channel 0's device is the loop's clock
    can.follower_wait_ns = cfg.grant_timeout_ns;
    can.stop = stop;
    out->push_back(MakeCanDevice(can));
    if (out->back() == nullptr) return "can: bus driver not available in this build";
  }
  return "";
}

std::string MakeModbusChannels(const platform::FirmwareConfig& cfg,
                               std::vector<std::unique_ptr<BusDevice>>* out) {
  auto link = std::make_shared<ModbusChannels>(cfg.io.modbus, cfg.channels.modbus_device_profiles);
  if (std::string why; !link->ok(&why)) return "modbus: " + why;
  for (std::size_t k = 0; k < link->size(); ++k) {
    out->push_back(std::make_unique<LinkChannel>(link, k));
  }
  return "";
}

}  // namespace

ChannelBus ChannelBusOf(const platform::FirmwareConfig& cfg) {
  if (!cfg.channels.modbus_profiles.empty()) {
    return {"modbus", cfg.io.modbus.inputs, &cfg.channels.modbus_profiles};
  }
  return {"can", cfg.io.can.inputs, &cfg.channels.can_profiles};
}

std::string MakeChannelDevices(const platform::FirmwareConfig& cfg, const std::atomic<bool>* stop,
                               std::vector<std::unique_ptr<BusDevice>>* out) {
  if (!cfg.channels.modbus_device_profiles.empty()) return MakeModbusChannels(cfg, out);
  return MakeCanChannels(cfg, stop, out);
}

}  // namespace mrd::firmware
