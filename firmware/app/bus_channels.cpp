#include "bus_channels.hpp"

#include <cstdio>

#include "channel_devices.hpp"
#include "channel_models.hpp"
#include "demo_table.hpp"
#include "mrd/common/input_file.hpp"

namespace mrd::firmware {
namespace {

constexpr int kReady = -1;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

}  // namespace

// One channel: its device, its I/O over it, its controller, its telemetry, the channel.
struct BusChannels::Corner {
  std::unique_ptr<BusDevice> device;
  FieldbusIo io;
  Controller controller;
  Telemetry* telemetry = nullptr;
  std::unique_ptr<Channel> channel;
};

BusChannels::BusChannels(const BusChannelsRun& run, Telemetry* first)
    : run_(run), first_(first), rest_(static_cast<std::size_t>(run.cfg.channels.count) - 1) {}

BusChannels::~BusChannels() {
  for (auto& c : corners_) {
    if (c->device) c->device->Deactivate();
  }
}

// Models, controllers and devices (not yet started): "" or the refusal (exit 2).
std::string BusChannels::MakeCorners() {
  const platform::FirmwareConfig& cfg = run_.cfg;
  ChannelModels loaded;
  if (std::string why = LoadChannelModels(cfg, run_.run_table, run_.run_table_name, &loaded);
      !why.empty()) {
    return why;
  }
  if (loaded.any_demo && !run_.allow_demo_table && !RealDeviceOf(cfg.io).empty()) {
    return "a channel's table is the demo table, a model of the reference damper, not of "
           "yours: refusing to drive " +
           RealDeviceOf(cfg.io) +
           " with it. Identify your dampers (docs/guide/identify.md) and give their tables in "
           "[channels] tables, or pass --allow-demo-table";
  }
  std::vector<std::unique_ptr<BusDevice>> devices;
  if (std::string why = MakeChannelDevices(cfg, run_.stop, &devices); !why.empty()) return why;
  if (devices.size() != loaded.models.size()) return "[channels]: not one device per channel";
  const ChannelBus bus = ChannelBusOf(cfg);
  for (std::size_t i = 0; i < loaded.models.size(); ++i) {
    auto c = std::make_unique<Corner>();
    if (!c->controller.Configure(loaded.models[i], cfg.controller).ok()) {
      return "channel " + std::to_string(i) + ": the configuration is refused with its table " +
             ChannelTableName(cfg, run_.run_table_name, i);
    }
    if (c->controller.runtime().reads_displacement() &&
        (bus.inputs & Bit(Input::kDisplacement)) == 0) {
      return "channel " + std::to_string(i) + ": the model of table " +
             ChannelTableName(cfg, run_.run_table_name, i) + " reads the displacement, but [" +
             bus.section + "] does not serve input 'displacement'";
    }
    c->device = std::move(devices[i]);
    c->telemetry = i == 0 ? first_ : &rest_[i - 1];
    c->channel = std::make_unique<Channel>(c->io, c->io, c->controller, *c->telemetry);
    (void)c->io.Add(c->device.get());  // one device: within FieldbusIo::kMaxDevices
    corners_.push_back(std::move(c));
  }
  return "";
}

int BusChannels::Start() {
  const platform::FirmwareConfig& cfg = run_.cfg;
  if (std::string why = MakeCorners(); !why.empty()) {
    std::fprintf(stderr, "error: %s: %s\n", run_.config_path, Printable(why).c_str());
    return kExitBadInput;
  }
  for (std::size_t i = 0; i < corners_.size(); ++i) {
    std::string error;
    BusDevice& d = *corners_[i]->device;
    if (!d.Configure(&error) || !d.Activate(&error)) {
      std::fprintf(stderr, "error: channel %zu (%s): %s\n", i,
                   Printable((*ChannelBusOf(cfg).profiles)[i]).c_str(), error.c_str());
      return kExitFailure;
    }
  }
  Clock* clock = &monotonic_;
  if (cfg.clock == platform::LoopClock::kGrant) {
    TimeGrantSource* grants = corners_[0]->device->grant_source();
    if (grants == nullptr) {
      std::fprintf(stderr, "error: %s: clock = \"grant\": channel 0's device gives no grants\n",
                   run_.config_path);
      return kExitBadInput;
    }
    grant_clock_.emplace(*grants, cfg.grant_timeout_ns, run_.stop);
    clock = &*grant_clock_;
  }
  std::vector<Channel*> list;
  for (auto& c : corners_) list.push_back(c->channel.get());
  loop_.emplace(*clock, list.data(), list.size(), cfg.channels.fault_policy, cfg.period_ns);
  if (!loop_->ok()) {  // the config allows 1 ... kMaxChannels and a period > 0
    std::fprintf(stderr, "error: %s: the channels cannot run on one loop\n", run_.config_path);
    return kExitBadInput;
  }
  if (cfg.channels.body_law == platform::BodyLawKind::kModalSkyhook) {
    if (skyhook_.Configure(cfg.channels.geometry, cfg.channels.gains) != Error::kOk) {
      std::fprintf(stderr, "error: %s: [channels] body_law: modal skyhook refused\n",
                   run_.config_path);
      return kExitBadInput;
    }
    loop_->SetBodyLaw(&body_law_);
  }
  return kReady;
}

void BusChannels::Finish(std::vector<std::unique_ptr<BusDevice>>* devices,
                         std::vector<DeviceFaults>* faults,
                         std::vector<SummaryInfo::Channel>* channels) {
  for (std::size_t i = 0; i < corners_.size(); ++i) {
    Corner& c = *corners_[i];
    c.device->Deactivate();
    const DeviceFaults f = c.io.faults(0);
    SummaryInfo::Channel ch{ChannelTableName(run_.cfg, run_.run_table_name, i),
                            c.telemetry->Read()};
    ch.has_device = true;
    ch.device = {c.device->name(), c.device->counters(), f};
    channels->push_back(ch);
    faults->push_back(f);
    devices->push_back(std::move(c.device));
  }
}

}  // namespace mrd::firmware
