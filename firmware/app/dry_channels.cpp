#include "dry_channels.hpp"

#include <memory>
#include <numbers>

#include "channel_models.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/modal_body_law.hpp"
#include "mrd/firmware/shared_model.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"

namespace mrd::firmware {
namespace {

using platform::BodyLawKind;

// One corner: its plant, controller and counters (the channel on them).
struct Corner {
  Corner(const mrd::SpencerParams& damper, const SimulationConfig& excitation, Clock& clock,
         std::int64_t period_ns, Telemetry& t)
      : plant(damper, excitation, clock, period_ns), telemetry(t) {}
  SimulatedDamper plant;
  Controller controller;
  Telemetry& telemetry;
  std::unique_ptr<Channel> channel;
};

// Channel i's excitation: the config's with the stroke 8 % smaller and the body an eighth of
// a period later per channel (channel 0: the config's), so that no two corners move alike.
SimulationConfig CornerExcitation(const SimulationConfig& base, std::size_t i) {
  SimulationConfig c = base;
  c.amplitude_cm *= 1.0 - 0.08 * static_cast<double>(i);
  c.body_phase_rad += static_cast<double>(i) * std::numbers::pi / 4.0;
  return c;
}

// The corners on clock, each configured on its model; "" or the refusal.
std::string MakeCorners(const DryChannelsRun& run, Clock& clock, Telemetry* first,
                        std::vector<Telemetry>* rest, std::vector<std::unique_ptr<Corner>>* out) {
  ChannelModels loaded;
  if (std::string why = LoadChannelModels(run.cfg, run.run_table, run.run_table_name, &loaded);
      !why.empty()) {
    return why;
  }
  const auto& models = loaded.models;
  for (std::size_t i = 0; i < models.size(); ++i) {
    Telemetry& t = i == 0 ? *first : (*rest)[i - 1];
    auto c = std::make_unique<Corner>(run.damper, CornerExcitation(run.cfg.simulation, i), clock,
                                      run.cfg.period_ns, t);
    if (!c->controller.Configure(models[i], run.cfg.controller).ok()) {
      return "channel " + std::to_string(i) + ": the configuration is refused with its table";
    }
    c->channel = std::make_unique<Channel>(c->plant, c->plant, c->controller, c->telemetry);
    out->push_back(std::move(c));
  }
  return "";
}

void RunLoop(const DryChannelsRun& run, Clock& clock, std::vector<std::unique_ptr<Corner>>& corners,
             const std::atomic<bool>& stop) {
  std::vector<Channel*> list;
  for (auto& c : corners) list.push_back(c->channel.get());
  Loop loop(clock, list.data(), list.size(), run.cfg.channels.fault_policy, run.cfg.period_ns);
  if (!loop.ok()) return;  // the config allows 1 ... kMaxChannels and a period > 0
  corners[0]->channel->SetObserver(run.observer);
  ModalSkyhook skyhook;
  ModalBodyLaw body_law(skyhook);
  if (run.cfg.channels.body_law == BodyLawKind::kModalSkyhook &&
      skyhook.Configure(run.cfg.channels.geometry, run.cfg.channels.gains) == Error::kOk) {
    loop.SetBodyLaw(&body_law);
  }
  loop.Run(stop, run.duration_ns);
}

}  // namespace

std::string RunDryChannels(const DryChannelsRun& run, const std::atomic<bool>& stop,
                           Telemetry* first, std::vector<SummaryInfo::Channel>* channels) {
  LockstepClock lockstep;
  MonotonicClock monotonic;
  Clock& clock = run.lockstep ? static_cast<Clock&>(lockstep) : monotonic;
  std::vector<Telemetry> rest(static_cast<std::size_t>(run.cfg.channels.count) - 1);
  std::vector<std::unique_ptr<Corner>> corners;
  if (std::string why = MakeCorners(run, clock, first, &rest, &corners); !why.empty()) return why;
  RunLoop(run, clock, corners, stop);
  for (std::size_t i = 0; i < corners.size(); ++i) {
    channels->push_back(
        {ChannelTableName(run.cfg, run.run_table_name, i), corners[i]->telemetry.Read()});
  }
  return "";
}

}  // namespace mrd::firmware
