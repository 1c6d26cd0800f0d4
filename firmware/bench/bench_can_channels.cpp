// Google Benchmark: one loop period with N damper channels over CAN, 1, 2, 4 and 8: each channel
// with its own CAN device (the built-in mrd-native profile) on a socketpair of its own, as
// several channels on one bus run (bus_channels.hpp): every device's drain of its step's two
// sensor frames, the update (force tracking on the compiled-in table), the command frame sent,
// the telemetry. The peer's writes of the sensor frames and its reads of the commands are not
// timed (PauseTiming, whose own cost of about a microsecond per pause is in the figure).
#include <benchmark/benchmark.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <memory>
#include <vector>

#include "mrd/common/clock.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace {

using namespace mrd::firmware;  // NOLINT: benchmark file
namespace pc = mrd::protocol::can;

struct CanCorner {
  int peer = -1;
  std::unique_ptr<CanDevice> device;
  FieldbusIo io;
  Controller controller;
  Telemetry telemetry;
  std::unique_ptr<Channel> channel;
  ~CanCorner() {
    device.reset();
    if (peer >= 0) close(peer);
  }
};

void BM_LoopPeriodCan(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  mrd::Error error = mrd::Error::kOk;
  const auto shared = SharedModel::Load(kBuiltinTable, &error);
  std::vector<std::unique_ptr<CanCorner>> corners;
  std::vector<Channel*> list;
  ControllerConfig k;
  k.law.mode = ControlMode::kForceTracking;
  for (std::size_t i = 0; i < n; ++i) {
    auto c = std::make_unique<CanCorner>();
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv) != 0) {
      state.SkipWithError("socketpair");
      return;
    }
    c->peer = sv[1];
    CanConfig can;
    can.enabled = true;
    can.inputs = Bit(Input::kVelocity) | Bit(Input::kDemand);
    can.outputs = Bit(Output::kCommand);
    can.max_age_ns = 1'000'000'000;  // the untimed peer work must not age the samples
    c->device = std::make_unique<CanDevice>(can, sv[0]);
    std::string why;
    if (!c->device->Activate(&why) || !c->io.Add(c->device.get()) ||
        !c->controller.Configure(shared, k).ok()) {
      state.SkipWithError("start-up");
      return;
    }
    c->channel = std::make_unique<Channel>(c->io, c->io, c->controller, c->telemetry);
    list.push_back(c->channel.get());
    corners.push_back(std::move(c));
  }
  MonotonicClock clock;
  Loop loop(clock, list.data(), list.size(), FaultPolicy::kAll, 1'000'000);
  std::uint8_t counter = 0;
  std::uint16_t seq = 0;
  char drain[64];
  for (auto _ : state) {
    state.PauseTiming();
    const double v = 12.0 * std::sin(0.0125 * seq);
    for (std::size_t i = 0; i < n; ++i) {
      can_frame f{};
      pc::Encode(pc::SensorMotion{v, 0.0, seq, counter}, &f);
      (void)write(corners[i]->peer, &f, sizeof f);
      pc::Encode(pc::SensorForce{60.0 * v * (1.0 + 0.1 * static_cast<double>(i)), 0.0, 0.0,
                                 counter},
                 &f);
      (void)write(corners[i]->peer, &f, sizeof f);
    }
    counter = static_cast<std::uint8_t>((counter + 1) & 15);
    ++seq;
    state.ResumeTiming();
    loop.Tick(mrd::common::MonotonicNs());
    state.PauseTiming();
    for (const auto& c : corners) {
      while (recv(c->peer, drain, sizeof drain, MSG_DONTWAIT) > 0) {
      }
    }
    state.ResumeTiming();
  }
  state.counters["channels"] = static_cast<double>(n);
  state.counters["safe_entries_ch0"] = static_cast<double>(loop.stats().watchdog.entries);
}
BENCHMARK(BM_LoopPeriodCan)->Arg(1)->Arg(2)->Arg(4)->Arg(8);

}  // namespace
