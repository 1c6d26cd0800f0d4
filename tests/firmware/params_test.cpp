// Runtime parameters: the key table as parameters (same ranges as the config), the retune of a
// running controller, and the mailbox that applies changes and reloads at a period boundary.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/firmware/platform/runtime_params.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"
#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;

const platform::ParamInfo* Find(const std::vector<platform::ParamInfo>& list,
                                const std::string& name) {
  for (const platform::ParamInfo& p : list) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

std::string ValueOf(const platform::FirmwareConfig& c, const std::string& name) {
  const std::vector<platform::ParamInfo> list = platform::ListParams(c);
  const platform::ParamInfo* p = Find(list, name);
  return p != nullptr ? p->value : "(missing)";
}

TEST(ParamTableTest, EveryKeyIsAParameterWithTypeUnitRangeAndWhenItApplies) {
  platform::FirmwareConfig c;
  const std::vector<platform::ParamInfo> list = platform::ListParams(c);
  ASSERT_GT(list.size(), 40U);
  const platform::ParamInfo* gain = Find(list, "control.skyhook_gain");
  ASSERT_NE(gain, nullptr);
  EXPECT_EQ(gain->value, "100.0");
  EXPECT_EQ(gain->type, "float");
  EXPECT_EQ(gain->unit, "N s/cm");
  EXPECT_EQ(gain->accepts, "[0.0, 1e+06]");
  EXPECT_EQ(gain->tunable, platform::Tunable::kRuntime);
  for (const char* name :
       {"control.law", "control.e_max", "control.constant_voltage", "control.force_limit",
        "velocity.cutoff_hz", "safety.recover_periods", "safety.velocity_limit",
        "safety.displacement_limit", "envelope.hold", "envelope.margin"}) {
    const platform::ParamInfo* p = Find(list, name);
    ASSERT_NE(p, nullptr) << name;
    EXPECT_EQ(p->tunable, platform::Tunable::kRuntime) << name;
  }
  EXPECT_EQ(Find(list, "velocity.source")->tunable, platform::Tunable::kReload);
  for (const char* name :
       {"loop.period_us", "loop.clock", "safety.safe_voltage", "safety.max_age_ms",
        "simulation.substeps", "can.inputs", "modbus.port", "ctl.socket"}) {
    const platform::ParamInfo* p = Find(list, name);
    ASSERT_NE(p, nullptr) << name;
    EXPECT_EQ(p->tunable, platform::Tunable::kRestart) << name;
  }
  // The reference marks them the same way.
  const std::string ref = platform::ConfigReference();
  EXPECT_NE(ref.find("| `skyhook_gain` | `100.0` | N s/cm | [0.0, 1e+06] | runtime |"),
            std::string::npos);
  EXPECT_NE(ref.find("| `period_us` | `1000.0` | us | [100.0, 1e+06] | restart |"),
            std::string::npos);
  EXPECT_NE(ref.find("| `source` | `\"measured\"` |  | measured or displacement | reload |"),
            std::string::npos);
}

TEST(ParamTableTest, SetAcceptsValidValuesAndRefusesTheRestUnchanged) {
  platform::FirmwareConfig c;
  std::string why;
  ASSERT_TRUE(platform::SetParam(&c, "control.skyhook_gain", "40", &why)) << why;
  EXPECT_DOUBLE_EQ(c.controller.law.skyhook_gain, 40.0);
  ASSERT_TRUE(platform::SetParam(&c, "control.law", "skyhook", &why)) << why;  // a bare word
  EXPECT_EQ(c.controller.law.mode, ControlMode::kSkyhookContinuous);
  ASSERT_TRUE(platform::SetParam(&c, "control.law", "\"constant\"", &why)) << why;  // TOML string
  EXPECT_EQ(c.controller.law.mode, ControlMode::kConstantVoltage);
  ASSERT_TRUE(platform::SetParam(&c, "envelope.hold", "false", &why)) << why;
  EXPECT_FALSE(c.controller.envelope);
  ASSERT_TRUE(platform::SetParam(&c, "safety.recover_periods", "20", &why)) << why;
  EXPECT_EQ(c.controller.watchdog.recover_periods, 20U);
  ASSERT_TRUE(platform::SetParam(&c, "control.e_max", "1.5", &why)) << why;
  EXPECT_DOUBLE_EQ(c.controller.e_max, 1.5);
  ASSERT_TRUE(c.e_max.has_value());
  EXPECT_DOUBLE_EQ(*c.e_max, 1.5);

  const platform::FirmwareConfig before = c;
  struct Bad {
    const char* name;
    const char* value;
    const char* says;
  };
  const Bad bad[] = {
      {"control.skyhook_gain", "-1", "must be in [0.0, 1e+06]"},
      {"control.skyhook_gain", "2e6", "must be in [0.0, 1e+06]"},
      {"control.skyhook_gain", "nan", "must be in"},
      {"control.skyhook_gain", "abc", "must be a number"},
      {"control.skyhook_gain", "\"40\"", "must be a number"},
      {"safety.recover_periods", "2.5", "must be an integer"},
      {"safety.recover_periods", "0", "must be in [1, 1000000]"},
      {"envelope.hold", "1", "must be true or false"},
      {"control.law", "fast", "must be one of force | constant | skyhook-on-off | skyhook"},
      {"control.nope", "1", "unknown parameter 'control.nope'"},
      {"nope", "1", "unknown parameter 'nope'"},
      {"loop.period_us", "500", "loop.period_us is not tunable at runtime: it needs a restart"},
      {"velocity.source", "displacement",
       "not tunable at runtime: change it in the config file "
       "and reload (SIGHUP)"},
      {"safety.safe_voltage", "0.1", "not tunable at runtime"},
      {"control.skyhook_gain", "1\nx = 2", "must be a number"},
  };
  for (const Bad& b : bad) {
    platform::FirmwareConfig d = c;
    EXPECT_FALSE(platform::SetParam(&d, b.name, b.value, &why)) << b.name << " " << b.value;
    EXPECT_NE(why.find(b.says), std::string::npos) << why;
    EXPECT_EQ(platform::ListParams(d).size(), platform::ListParams(before).size());
    for (std::size_t i = 0; i < platform::ListParams(d).size(); ++i) {
      EXPECT_EQ(platform::ListParams(d)[i].value, platform::ListParams(before)[i].value) << b.name;
    }
  }
}

// One code path: a runtime key accepts exactly what the config file accepts for it.
TEST(ParamTableTest, RuntimeRangesAreTheConfigRanges) {
  const platform::FirmwareConfig base;
  const char* values[] = {"-1e12",     "-1",          "-0.5",    "0",    "1e-10", "0.5",
                          "1",         "2",           "3",       "99.5", "100",   "100.5",
                          "1e5",       "1e6",         "1000001", "1e9",  "1e10",  "true",
                          "\"force\"", "\"skyhook\"", "\"x\"",   "inf",  "nan"};
  int compared = 0;
  for (const platform::ParamInfo& p : platform::ListParams(base)) {
    if (p.tunable != platform::Tunable::kRuntime) continue;
    const auto dot = p.name.find('.');
    const std::string section = p.name.substr(0, dot), key = p.name.substr(dot + 1);
    for (const char* v : values) {
      platform::FirmwareConfig by_file = base, by_set = base;
      std::string error, why;
      const bool file_ok = platform::ParseConfig("[" + section + "]\n" + key + " = " + v + "\n",
                                                 "t.toml", &by_file, &error);
      const bool set_ok = platform::SetParam(&by_set, p.name, v, &why);
      EXPECT_EQ(file_ok, set_ok) << p.name << " = " << v << ": " << error << " / " << why;
      if (file_ok && set_ok && p.name != "control.e_max") {
        EXPECT_EQ(ValueOf(by_file, p.name), ValueOf(by_set, p.name)) << p.name << " = " << v;
      }
      ++compared;
    }
  }
  EXPECT_GT(compared, 200);
}

TEST(ParamTableTest, SetRefusesWhatTheBusesCannotServe) {
  platform::FirmwareConfig c;
  std::string error;
  ASSERT_TRUE(
      platform::ParseConfig("[can]\ninputs = [\"velocity\", \"demand\"]\noutputs = [\"command\"]\n"
                            "local_bus = \"/tmp/x.sock\"\n",
                            "bus.toml", &c, &error))
      << error;
  std::string why;
  EXPECT_FALSE(platform::SetParam(&c, "control.law", "skyhook", &why));
  EXPECT_NE(why.find("no bus serves input 'body_velocity' (skyhook laws)"), std::string::npos)
      << why;
  EXPECT_EQ(c.controller.law.mode, ControlMode::kForceTracking);
  EXPECT_FALSE(platform::SetParam(&c, "safety.displacement_limit", "5", &why));
  EXPECT_NE(why.find("displacement_limit needs a measured displacement"), std::string::npos) << why;
  EXPECT_TRUE(platform::SetParam(&c, "control.law", "constant", &why)) << why;
}

TEST(ParamTableTest, RestartKeysChangedNamesThem) {
  platform::FirmwareConfig a, b;
  std::string error;
  ASSERT_TRUE(
      platform::ParseConfig("[control]\nlaw = \"skyhook\"\n[velocity]\nsource = \"displacement\"\n",
                            "b.toml", &b, &error));
  EXPECT_TRUE(RestartKeysChanged(a, b).empty());  // runtime and reload keys only
  ASSERT_TRUE(platform::ParseConfig("[loop]\nperiod_us = 500\n[safety]\nsafe_voltage = 0.1\n",
                                    "b.toml", &b, &error));
  EXPECT_EQ(RestartKeysChanged(a, b),
            (std::vector<std::string>{"loop.period_us", "safety.safe_voltage"}));
  platform::FirmwareConfig c;
  ASSERT_TRUE(platform::ParseConfig(
      "[modbus]\ninputs = [\"velocity\", \"demand\"]\noutputs = [\"command\"]\n"
      "host = \"localhost\"\nport = 1502\n",
      "c.toml", &c, &error))
      << error;
  const std::vector<std::string> changed = RestartKeysChanged(a, c);
  EXPECT_NE(std::find(changed.begin(), changed.end(), "[modbus]"), changed.end());
  EXPECT_NE(std::find(changed.begin(), changed.end(), "modbus.port"), changed.end());
}

// --- Controller::Retune ---

SensorFrame Frame(std::int64_t now, double v, double vb) {
  SensorFrame f;
  f[Input::kVelocity] = {v, now};
  f[Input::kDisplacement] = {0.1, now};
  f[Input::kDemand] = {300.0, now};
  f[Input::kBodyVelocity] = {vb, now};
  return f;
}

TEST(ControllerRetuneTest, KeepsTheModelStateAndChangesTheLaw) {
  ControllerConfig cfg;
  cfg.law.mode = ControlMode::kSkyhookContinuous;
  cfg.law.skyhook_gain = 20.0;
  Controller a, b;
  ASSERT_EQ(a.Configure(test::DemoDamperTable(), cfg), Error::kOk);
  ASSERT_EQ(b.Configure(test::DemoDamperTable(), cfg), Error::kOk);
  std::int64_t now = 0;
  for (int k = 0; k < 200; ++k) {
    now += kPeriod;
    const SensorFrame f = Frame(now, 10.0 * std::sin(k * 0.05), 5.0 * std::cos(k * 0.05));
    (void)a.Update(f, IoStatus::kOk, false, now, 1e-3);
    (void)b.Update(f, IoStatus::kOk, false, now, 1e-3);
  }
  // A retune with the same values changes nothing: the model's history is kept (a reset
  // would show as a different model force).
  ASSERT_EQ(b.Retune(cfg), Error::kOk);
  now += kPeriod;
  const SensorFrame f = Frame(now, 4.0, 3.0);
  const ControllerOutput oa = a.Update(f, IoStatus::kOk, false, now, 1e-3);
  ControllerOutput ob = b.Update(f, IoStatus::kOk, false, now, 1e-3);
  EXPECT_EQ(oa.model_force, ob.model_force);
  EXPECT_EQ(oa.force_demand, ob.force_demand);
  // A new gain shows at once: f_d = c_sky vb (vb v > 0).
  ControllerConfig faster = cfg;
  faster.law.skyhook_gain = 60.0;
  ASSERT_EQ(b.Retune(faster), Error::kOk);
  now += kPeriod;
  ob = b.Update(Frame(now, 4.0, 3.0), IoStatus::kOk, false, now, 1e-3);
  EXPECT_NEAR(ob.force_demand, 180.0, 1e-3);
  EXPECT_EQ(b.model_resets(), 0U);
  EXPECT_DOUBLE_EQ(b.config().law.skyhook_gain, 60.0);
}

TEST(ControllerRetuneTest, RefusesWhatConfigureRefusesAndChangesNothing) {
  ControllerConfig cfg;
  Controller c;
  ASSERT_EQ(c.Configure(test::DemoDamperTable(), cfg), Error::kOk);
  ControllerConfig bad = cfg;
  bad.e_max = test::DemoDamperTable().e_max + 1.0;
  EXPECT_EQ(c.Retune(bad), Error::kOutOfRange);
  bad = cfg;
  bad.envelope_margin = -1.0;
  EXPECT_EQ(c.Retune(bad), Error::kOutOfRange);
  bad = cfg;
  bad.law.mode = ControlMode::kConstantVoltage;
  bad.law.constant_voltage = 99.0;
  EXPECT_EQ(c.Retune(bad), Error::kOutOfRange);
  bad = cfg;
  bad.watchdog.recover_periods = 0;
  EXPECT_EQ(c.Retune(bad), Error::kOutOfRange);
  bad = cfg;
  bad.velocity_source = VelocitySource::kDisplacement;
  EXPECT_EQ(c.Retune(bad), Error::kInvalidArgument);
  bad = cfg;
  bad.safe_voltage = 0.5;
  EXPECT_EQ(c.Retune(bad), Error::kInvalidArgument);
  EXPECT_EQ(c.config().law.mode, cfg.law.mode);
  EXPECT_EQ(c.config().e_max, cfg.e_max);
  EXPECT_EQ(c.config().envelope_margin, cfg.envelope_margin);
}

// --- The mailbox at a period boundary (lockstep) ---

struct Recorder final : PeriodObserver {
  std::vector<PeriodRecord> records;
  void OnPeriod(const PeriodRecord& r) override { records.push_back(r); }
};

platform::FirmwareConfig ConstantHalfVolt() {
  platform::FirmwareConfig config;
  config.controller.law.mode = ControlMode::kConstantVoltage;
  config.controller.law.constant_voltage = 0.5;
  config.controller.e_max = test::DemoDamperTable().e_max;
  return config;
}

struct Rig {
  Rig() {
    EXPECT_EQ(controller.Configure(test::DemoDamperTable(), config.controller), Error::kOk);
    loop.SetHook(&params);
    loop.SetObserver(&recorder);
    records().reserve(4096);
  }
  std::vector<PeriodRecord>& records() { return recorder.records; }
  void Ticks(int n) {
    for (int k = 0; k < n; ++k) {
      clock.Advance(kPeriod);
      loop.Tick(clock.Now());
    }
  }
  platform::FirmwareConfig config = ConstantHalfVolt();
  LockstepClock clock;
  SimulatedDamper plant{SpencerParams::Paper(), SimulationConfig{}, clock, kPeriod};
  Controller controller;
  Telemetry telemetry;
  Loop loop{clock, plant, plant, controller, telemetry, kPeriod};
  platform::RuntimeParams params{test::DemoDamperTable(), config};
  Recorder recorder;
};

TEST(ParamMailboxTest, AChangeAppliesAtTheNextPeriodAndTheRecordShowsIt) {
  Rig rig;
  rig.Ticks(100);
  ASSERT_EQ(rig.params.PostSet("control.constant_voltage", "1.5").status,
            platform::RuntimeParams::Status::kOk);
  EXPECT_EQ(rig.params.config().controller.law.constant_voltage, 0.5);  // not yet applied
  rig.Ticks(50);
  const platform::RuntimeParams::Result r = rig.params.Finish(1000);
  ASSERT_EQ(r.status, platform::RuntimeParams::Status::kOk) << r.message;
  EXPECT_EQ(r.period, 100U);  // the first period after the post
  EXPECT_EQ(r.version, 1U);
  EXPECT_EQ(rig.params.config().controller.law.constant_voltage, 1.5);
  EXPECT_EQ(rig.params.changes(), 1U);
  ASSERT_EQ(rig.records().size(), 150U);
  int before = 0, after = 0;
  for (const PeriodRecord& rec : rig.records()) {
    EXPECT_EQ(rec.param_version, rec.period < 100 ? 0U : 1U) << rec.period;
    if (rec.safe) continue;
    EXPECT_DOUBLE_EQ(rec.command_v, rec.period < 100 ? 0.5 : 1.5) << rec.period;
    ++(rec.period < 100 ? before : after);
  }
  EXPECT_GT(before, 50);
  EXPECT_GT(after, 40);
  EXPECT_EQ(rig.loop.stats().model_resets, 0U);
}

TEST(ParamMailboxTest, SetFromAnotherThreadWaitsForTheLoop) {
  Rig rig;
  rig.Ticks(10);
  std::atomic<bool> done{false};
  platform::RuntimeParams::Result r;
  std::thread setter([&] {
    r = rig.params.Set("control.constant_voltage", "2.0", 60'000);
    done = true;
  });
  int ticks = 0;
  while (!done.load() && ticks < 10'000'000) {
    rig.Ticks(1);
    ++ticks;
    std::this_thread::yield();
  }
  setter.join();
  ASSERT_EQ(r.status, platform::RuntimeParams::Status::kOk) << r.message;
  ASSERT_GT(rig.records().size(), r.period);
  EXPECT_EQ(rig.records()[static_cast<std::size_t>(r.period)].param_version, 1U);
  EXPECT_EQ(rig.records()[static_cast<std::size_t>(r.period - 1)].param_version, 0U);
  rig.Ticks(5);
  EXPECT_FALSE(rig.records().back().safe);
  EXPECT_DOUBLE_EQ(rig.records().back().command_v, 2.0);
}

TEST(ParamMailboxTest, RefusedValuesAndTimeoutsChangeNothing) {
  Rig rig;
  rig.Ticks(10);
  platform::RuntimeParams::Result r = rig.params.Set("control.constant_voltage", "9", 1000);
  EXPECT_EQ(r.status, platform::RuntimeParams::Status::kRefused);
  EXPECT_NE(r.message.find("out of range for the table"), std::string::npos) << r.message;
  r = rig.params.Set("control.skyhook_gain", "x", 1000);
  EXPECT_EQ(r.status, platform::RuntimeParams::Status::kRefused);
  // Nobody ticks: the request is withdrawn after the timeout and never applied later.
  r = rig.params.Set("control.constant_voltage", "1.0", 20);
  EXPECT_EQ(r.status, platform::RuntimeParams::Status::kFailed);
  EXPECT_NE(r.message.find("no period ran within 20 ms"), std::string::npos) << r.message;
  rig.Ticks(20);
  EXPECT_EQ(rig.params.version(), 0U);
  EXPECT_EQ(rig.params.config().controller.law.constant_voltage, 0.5);
  EXPECT_DOUBLE_EQ(rig.records().back().command_v, 0.5);
  // After the loop ended nothing is posted.
  rig.params.LoopEnded();
  r = rig.params.Set("control.constant_voltage", "1.0", 1000);
  EXPECT_EQ(r.status, platform::RuntimeParams::Status::kFailed);
}

TEST(ParamMailboxTest, AReloadSwapsAFreshControllerAtABoundaryAndCountsOn) {
  Rig rig;
  rig.Ticks(300);
  const std::uint64_t safe_periods = rig.loop.stats().watchdog.safe_periods;
  platform::FirmwareConfig next = rig.config;
  next.controller.law.constant_voltage = 1.0;
  next.controller.velocity_source = VelocitySource::kDisplacement;  // a reload key
  std::atomic<bool> done{false};
  platform::RuntimeParams::Result r;
  std::thread reloader([&] {
    r = rig.params.Reload(next, test::DemoDamperTable(), nullptr, 60'000);
    done = true;
  });
  while (!done.load()) {
    rig.Ticks(1);
    std::this_thread::yield();
  }
  reloader.join();
  ASSERT_EQ(r.status, platform::RuntimeParams::Status::kOk) << r.message;
  EXPECT_EQ(rig.params.reloads(), 1U);
  EXPECT_NE(&rig.loop.controller(), &rig.controller);  // a fresh one runs
  EXPECT_EQ(rig.loop.controller().config().velocity_source, VelocitySource::kDisplacement);
  EXPECT_EQ(rig.records()[static_cast<std::size_t>(r.period)].param_version, 1U);
  EXPECT_EQ(rig.records()[static_cast<std::size_t>(r.period - 1)].param_version, 0U);
  rig.Ticks(10);
  EXPECT_GE(rig.loop.stats().watchdog.safe_periods, safe_periods);  // totals run on
  EXPECT_DOUBLE_EQ(rig.records().back().command_v, 1.0);

  // Refused: a restart key, a config the table refuses, an application check.
  platform::FirmwareConfig restart = next;
  restart.period_ns = 500'000;
  r = rig.params.Reload(restart, test::DemoDamperTable(), nullptr, 1000);
  EXPECT_EQ(r.status, platform::RuntimeParams::Status::kRefused);
  EXPECT_NE(r.message.find("loop.period_us"), std::string::npos) << r.message;
  platform::FirmwareConfig too_high = next;
  too_high.controller.e_max = 99.0;
  r = rig.params.Reload(too_high, test::DemoDamperTable(), nullptr, 1000);
  EXPECT_EQ(r.status, platform::RuntimeParams::Status::kRefused);
  EXPECT_NE(r.message.find("out of range for the table"), std::string::npos) << r.message;
  r = rig.params.Reload(
      next, test::DemoDamperTable(),
      [](const platform::FirmwareConfig&, const CoefficientTable&, const Controller&) {
        return std::string("no");
      },
      1000);
  EXPECT_EQ(r.status, platform::RuntimeParams::Status::kRefused);
  EXPECT_EQ(r.message, "no");
  EXPECT_EQ(rig.params.reloads(), 1U);
}

}  // namespace
}  // namespace mrd::firmware
