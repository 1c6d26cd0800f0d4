// mrd-firmware — MR damper controller: model + analytic inversion at a fixed period.
// Start-up (argument parsing, table and config loading, device configuration, real-time
// set-up) may allocate; the loop (Loop::Run) does not. With bus sections in the config the loop
// runs on the field devices (SocketCAN / local frame bus, Modbus, GPIO); with --dry-run it runs
// against the simulated Spencer damper.
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "mrd/common/table.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/config.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/fieldbus_io.hpp"
#include "mrd/firmware/io/devices.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/simulated_damper.hpp"
#include "mrd/firmware/table_file.hpp"

namespace {

using namespace mrd::firmware;  // NOLINT: application file

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

std::atomic<bool> g_stop{false};

extern "C" void OnSignal(int) { g_stop.store(true); }

constexpr const char* kHelp =
    "mrd-firmware: MR damper controller (polynomial NARX model + analytic voltage inversion).\n"
    "\n"
    "Usage:\n"
    "  mrd-firmware [--table FILE] --config FILE.toml [--duration SECONDS] [--json]\n"
    "  mrd-firmware [--table FILE] [--config FILE.toml] --dry-run SECONDS [--lockstep] [--json]\n"
    "  mrd-firmware [--table FILE] --write-table OUT.bin\n"
    "  mrd-firmware --help\n"
    "\n"
    "Options:\n"
    "  --table FILE        coefficient table (docs/table_format.md); default: the compiled-in\n"
    "                      table (firmware/include/mrd/firmware/builtin_table.hpp)\n"
    "  --config FILE       TOML configuration: period, E_max, safe state, control law, limits,\n"
    "                      and the buses ([can], [modbus], [gpio]: where each signal comes\n"
    "                      from, where the command goes; docs/firmware_config.md)\n"
    "  --duration SECONDS  with bus sections: stop after this long (default: run until\n"
    "                      SIGINT/SIGTERM)\n"
    "  --dry-run SECONDS   run the control loop that long against the built-in simulated\n"
    "                      Spencer damper, then print the counters\n"
    "  --lockstep          dry run in simulated time (no sleeping; deterministic, fast)\n"
    "  --json              print the counters as JSON\n"
    "  --write-table OUT   write the table image (e.g. the compiled-in one) and exit\n"
    "  --help              this text\n"
    "\n"
    "Real time: SCHED_FIFO and mlockall are requested when the config allows; without the\n"
    "privilege a warning is printed and the loop runs at normal priority.\n"
    "SIGINT/SIGTERM stop the loop and leave the driver in the safe state.\n"
    "Exit status: 0 ok, 1 failure, 2 bad input (arguments, config, refused table).\n";

struct Options {
  const char* table = nullptr;
  const char* config = nullptr;
  const char* write_table = nullptr;
  double dry_run_s = -1.0;
  double duration_s = -1.0;
  bool lockstep = false;
  bool json = false;
  bool help = false;
};

bool ParseArgs(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char** out) {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "error: %s needs a value\n", a.c_str());
        return false;
      }
      *out = argv[++i];
      return true;
    };
    if (a == "--help" || a == "-h") {
      o->help = true;
    } else if (a == "--table") {
      if (!value(&o->table)) return false;
    } else if (a == "--config") {
      if (!value(&o->config)) return false;
    } else if (a == "--write-table") {
      if (!value(&o->write_table)) return false;
    } else if (a == "--dry-run") {
      const char* v = nullptr;
      if (!value(&v)) return false;
      char* end = nullptr;
      o->dry_run_s = std::strtod(v, &end);
      if (end == v || *end != '\0' || !std::isfinite(o->dry_run_s) || o->dry_run_s <= 0.0) {
        std::fprintf(stderr, "error: --dry-run needs a positive number of seconds, got '%s'\n", v);
        return false;
      }
    } else if (a == "--duration") {
      const char* v = nullptr;
      if (!value(&v)) return false;
      char* end = nullptr;
      o->duration_s = std::strtod(v, &end);
      if (end == v || *end != '\0' || !std::isfinite(o->duration_s) || o->duration_s <= 0.0 ||
          o->duration_s > 1e9) {
        std::fprintf(stderr, "error: --duration needs a number of seconds in (0, 1e9], got '%s'\n", v);
        return false;
      }
    } else if (a == "--lockstep") {
      o->lockstep = true;
    } else if (a == "--json") {
      o->json = true;
    } else {
      std::fprintf(stderr, "error: unknown argument '%s' (see --help)\n", a.c_str());
      return false;
    }
  }
  return true;
}

struct RealTime {
  bool memory_locked = false;
  bool sched_fifo = false;
};

// Pre-faults stack pages the loop may touch, so a locked stack never page-faults.
void PrefaultStack() {
  volatile char stack[256 * 1024];
  for (std::size_t i = 0; i < sizeof stack; i += 4096) stack[i] = 0;
}

// Per-device counters: {"can": {"rx_ok": …, "errors": {"timeout": …}, …}, …} or text lines.
void PrintDevices(const std::vector<std::unique_ptr<BusDevice>>& devices, bool json) {
  for (std::size_t d = 0; d < devices.size(); ++d) {
    const DeviceCounters c = devices[d]->counters();
    const auto u = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
    if (json) {
      std::printf("%s\"%s\": {\"rx_ok\": %llu, \"rx_rejected\": %llu, \"tx_ok\": %llu, "
                  "\"tx_failed\": %llu, \"reconnects\": %llu, \"last_error\": \"%s\", "
                  "\"errors\": {",
                  d == 0 ? "" : ", ", devices[d]->name(), u(c.rx_ok), u(c.rx_rejected),
                  u(c.tx_ok), u(c.tx_failed), u(c.reconnects), IoErrorName(c.last_error));
      for (std::size_t i = 0; i < kNumIoErrors; ++i) {
        std::printf("%s\"%s\": %llu", i == 0 ? "" : ", ", IoErrorName(static_cast<IoError>(i)),
                    u(c.errors[i]));
      }
      std::printf("}}");
    } else {
      std::printf("  %-8s rx %llu (rejected %llu), tx %llu (failed %llu), reconnects %llu, "
                  "last error %s\n",
                  devices[d]->name(), u(c.rx_ok), u(c.rx_rejected), u(c.tx_ok), u(c.tx_failed),
                  u(c.reconnects), IoErrorName(c.last_error));
    }
  }
}

void PrintSummary(const TelemetrySnapshot& s, const Options& o, const FirmwareConfig& cfg,
                  const RealTime& rt, const char* table_name,
                  const std::vector<std::unique_ptr<BusDevice>>& devices) {
  const bool buses = !devices.empty();
  const char* mode = buses ? "bus" : (o.lockstep ? "lockstep" : "realtime");
  const double seconds = buses ? static_cast<double>(s.ticks) * static_cast<double>(cfg.period_ns) * 1e-9
                               : o.dry_run_s;
  const double rms_model =
      s.force_samples > 0 ? std::sqrt(s.sum_sq_model_error / static_cast<double>(s.force_samples)) : 0.0;
  const double rms_tracking =
      s.tracking_samples > 0
          ? std::sqrt(s.sum_sq_tracking_error / static_cast<double>(s.tracking_samples))
          : 0.0;
  const auto cause = [&](FaultCause c) { return static_cast<std::size_t>(c); };
  if (o.json) {
    std::printf("{\n");
    std::printf("  \"mode\": \"%s\",\n", mode);
    std::printf("  \"table\": \"%s\",\n", table_name);
    std::printf("  \"law\": \"%s\",\n", ControlModeName(cfg.controller.law.mode));
    std::printf("  \"seconds\": %.6g,\n", seconds);
    std::printf("  \"period_us\": %.6g,\n", static_cast<double>(cfg.period_ns) / 1e3);
    std::printf("  \"sched_fifo\": %s,\n", rt.sched_fifo ? "true" : "false");
    std::printf("  \"memory_locked\": %s,\n", rt.memory_locked ? "true" : "false");
    std::printf("  \"ticks\": %llu,\n", static_cast<unsigned long long>(s.ticks));
    std::printf("  \"overruns\": %llu,\n", static_cast<unsigned long long>(s.overruns));
    std::printf("  \"missed_periods\": %llu,\n", static_cast<unsigned long long>(s.missed_periods));
    std::printf("  \"worst_latency_us\": %.3f,\n", static_cast<double>(s.worst_latency_ns) / 1e3);
    std::printf("  \"worst_exec_us\": %.3f,\n", static_cast<double>(s.worst_exec_ns) / 1e3);
    std::printf("  \"read_faults\": %llu,\n", static_cast<unsigned long long>(s.read_faults));
    std::printf("  \"write_faults\": %llu,\n", static_cast<unsigned long long>(s.write_faults));
    std::printf("  \"unreachable_demands\": %llu,\n", static_cast<unsigned long long>(s.unreachable));
    std::printf("  \"model_resets\": %llu,\n", static_cast<unsigned long long>(s.model_resets));
    std::printf("  \"safe_periods\": %llu,\n", static_cast<unsigned long long>(s.watchdog.safe_periods));
    std::printf("  \"safe_entries\": %llu,\n", static_cast<unsigned long long>(s.watchdog.entries));
    std::printf("  \"watchdog\": {");
    for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
      std::printf("%s\"%s\": {\"trips\": %llu, \"periods\": %llu}", i == 0 ? "" : ", ",
                  FaultCauseName(static_cast<FaultCause>(i)),
                  static_cast<unsigned long long>(s.watchdog.trips[i]),
                  static_cast<unsigned long long>(s.watchdog.active_periods[i]));
    }
    std::printf("},\n");
    std::printf("  \"last_command_v\": %.6g,\n", s.last_command_v);
    std::printf("  \"model_force_n\": %.6g,\n", s.model_force_n);
    std::printf("  \"rms_model_error_n\": %.6g,\n", rms_model);
    std::printf("  \"rms_tracking_error_n\": %.6g,\n", rms_tracking);
    std::printf("  \"devices\": {");
    PrintDevices(devices, true);
    std::printf("},\n");
    std::printf("  \"final_safe_state\": %s\n", s.safe ? "true" : "false");
    std::printf("}\n");
    return;
  }
  std::printf("mrd-firmware %s (%s, %.6g s, period %.6g us, law %s, table %s)\n",
              buses ? "run" : "dry run", buses ? "buses" : (o.lockstep ? "lockstep" : "real time"),
              seconds,
              static_cast<double>(cfg.period_ns) / 1e3, ControlModeName(cfg.controller.law.mode),
              table_name);
  std::printf("  real time:        SCHED_FIFO %s, memory %s\n", rt.sched_fifo ? "yes" : "no",
              rt.memory_locked ? "locked" : "not locked");
  std::printf("  ticks:            %llu\n", static_cast<unsigned long long>(s.ticks));
  std::printf("  overruns:         %llu (missed periods %llu)\n",
              static_cast<unsigned long long>(s.overruns),
              static_cast<unsigned long long>(s.missed_periods));
  std::printf("  worst latency:    %.3f us\n", static_cast<double>(s.worst_latency_ns) / 1e3);
  std::printf("  worst execution:  %.3f us\n", static_cast<double>(s.worst_exec_ns) / 1e3);
  std::printf("  I/O faults:       read %llu, write %llu\n",
              static_cast<unsigned long long>(s.read_faults),
              static_cast<unsigned long long>(s.write_faults));
  std::printf("  safe state:       %llu periods, %llu entries; trips:",
              static_cast<unsigned long long>(s.watchdog.safe_periods),
              static_cast<unsigned long long>(s.watchdog.entries));
  for (std::size_t i = 0; i < kNumFaultCauses; ++i) {
    std::printf(" %s %llu", FaultCauseName(static_cast<FaultCause>(i)),
                static_cast<unsigned long long>(s.watchdog.trips[cause(static_cast<FaultCause>(i))]));
  }
  std::printf("\n  unreachable:      %llu force demands saturated\n",
              static_cast<unsigned long long>(s.unreachable));
  std::printf("  model resets:     %llu\n", static_cast<unsigned long long>(s.model_resets));
  std::printf("  last command:     %.6g V, model force %.6g N\n", s.last_command_v, s.model_force_n);
  std::printf("  RMS errors:       model vs plant %.6g N, demand vs plant %.6g N\n", rms_model,
              rms_tracking);
  if (buses) std::printf("  devices:\n");
  PrintDevices(devices, false);
  std::printf("  final state:      %s\n", s.safe ? "safe" : "NOT SAFE");
}

// Runs the loop on CLOCK_MONOTONIC in a thread of its own (SCHED_FIFO and locked memory when
// the config asks and the system allows; warnings otherwise) until g_stop or duration_ns
// (<= 0: until g_stop). The calling thread reads the telemetry meanwhile.
void RunRealTime(const FirmwareConfig& cfg, SensorSource& source, CurrentDriver& driver,
                 Controller& controller, Telemetry& telemetry, std::int64_t duration_ns,
                 RealTime* rt) {
  if (cfg.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      rt->memory_locked = true;
    } else {
      std::fprintf(stderr, "warning: mlockall failed (%s); memory not locked, page faults may "
                   "delay the loop (needs CAP_IPC_LOCK or a higher RLIMIT_MEMLOCK)\n",
                   std::strerror(errno));
    }
  }
  MonotonicClock clock;
  Loop loop(clock, source, driver, controller, telemetry, cfg.period_ns);
  std::atomic<bool> done{false};
  std::thread worker([&] {
    if (cfg.priority > 0) {
      sched_param sp{};
      sp.sched_priority = cfg.priority;
      const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
      if (err == 0) {
        rt->sched_fifo = true;
      } else {
        std::fprintf(stderr, "warning: SCHED_FIFO priority %d refused (%s); running at normal "
                     "priority, expect jitter (needs CAP_SYS_NICE or an rtprio limit)\n",
                     cfg.priority, std::strerror(err));
      }
    }
    PrefaultStack();
    loop.Run(g_stop, duration_ns);
    done = true;
  });
  // The telemetry is read here while the loop runs (no locks, no stopping it).
  while (!done.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    (void)telemetry.Read();
  }
  worker.join();
}

int Run(const Options& o) {
  // Table: file or compiled-in.
  mrd::CoefficientTable table = kBuiltinTable;
  const char* table_name = o.table != nullptr ? o.table : "compiled-in";
  if (o.table != nullptr) {
    const auto loaded = LoadTableFile(o.table);
    if (!loaded.ok()) {
      if (loaded.error() == mrd::Error::kIo) {
        std::fprintf(stderr, "error: table %s: cannot read (%s)\n", o.table, std::strerror(errno));
      } else {
        std::fprintf(stderr, "error: table %s refused: %s\n", o.table,
                     mrd::ErrorName(loaded.error()));
      }
      return kExitBadInput;
    }
    table = loaded.value();
  }
  if (o.write_table != nullptr) {
    const auto image = mrd::EncodeTable(table);
    if (!image.ok()) {
      std::fprintf(stderr, "error: table refused: %s\n", mrd::ErrorName(image.error()));
      return kExitBadInput;
    }
    FILE* f = std::fopen(o.write_table, "wb");
    if (f == nullptr || std::fwrite(image.value().data(), 1, image.value().size(), f) != image.value().size()) {
      std::fprintf(stderr, "error: cannot write %s\n", o.write_table);
      if (f != nullptr) std::fclose(f);
      return kExitFailure;
    }
    std::fclose(f);
    return kExitOk;
  }

  FirmwareConfig cfg;
  if (o.config != nullptr) {
    std::string error;
    if (!LoadConfigFile(o.config, &cfg, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return kExitBadInput;
    }
  }
  cfg.controller.e_max = cfg.e_max.value_or(table.e_max);
  Controller controller;
  const mrd::Error e = controller.Configure(table, cfg.controller);
  if (e != mrd::Error::kOk) {
    if (e == mrd::Error::kOutOfRange) {
      std::fprintf(stderr,
                   "error: configuration refused for table %s: value out of range (E_max %g and "
                   "safe voltage %g must lie in the table's [%g, %g] V; check the law settings)\n",
                   table_name, cfg.controller.e_max, cfg.controller.safe_voltage, table.e_min,
                   table.e_max);
    } else {
      std::fprintf(stderr, "error: table %s refused: %s\n", table_name, mrd::ErrorName(e));
    }
    return kExitBadInput;
  }
  const bool buses = cfg.io.any();
  if (buses && o.dry_run_s > 0.0) {
    std::fprintf(stderr, "error: --dry-run runs the simulated damper; %s has bus sections "
                 "([can], [modbus], [gpio]): drop --dry-run, or use a config without them\n",
                 o.config);
    return kExitBadInput;
  }
  if (!buses && o.dry_run_s <= 0.0) {
    std::fprintf(stderr, "error: nothing to run: give --config FILE with bus sections ([can], "
                 "[modbus], [gpio]) or --dry-run SECONDS (see --help)\n");
    return kExitBadInput;
  }
  if (buses && o.lockstep) {
    std::fprintf(stderr, "error: --lockstep is for --dry-run\n");
    return kExitBadInput;
  }
  const std::uint32_t served = cfg.io.can.inputs | cfg.io.modbus.inputs | cfg.io.gpio.inputs;
  if (buses && controller.runtime().reads_displacement() &&
      (served & Bit(Input::kDisplacement)) == 0) {
    std::fprintf(stderr, "error: %s: the model of table %s reads the displacement, but no bus "
                 "serves input 'displacement'\n", o.config, table_name);
    return kExitBadInput;
  }

  // Every terminating signal we can catch ends in the safe-state shutdown.
  struct sigaction sa {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGHUP, &sa, nullptr);
  sigaction(SIGQUIT, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);  // a peer closing a socket is an I/O error, not our death

  Telemetry telemetry;
  RealTime rt;
  std::vector<std::unique_ptr<BusDevice>> devices;
  if (buses) {
    std::string error;
    if (!MakeDevices(cfg.io, &devices, &error)) {
      std::fprintf(stderr, "error: %s: %s\n", o.config, error.c_str());
      return kExitBadInput;
    }
    FieldbusIo io;
    for (auto& d : devices) {
      if (!d->Configure(&error) || !d->Activate(&error)) {
        std::fprintf(stderr, "error: %s\n", error.c_str());
        for (auto& up : devices) up->Deactivate();
        return kExitFailure;
      }
      io.Add(d.get());
    }
    const std::int64_t duration_ns =
        o.duration_s > 0.0 ? static_cast<std::int64_t>(std::llround(o.duration_s * 1e9)) : 0;
    RunRealTime(cfg, io, io, controller, telemetry, duration_ns, &rt);
    for (auto& d : devices) d->Deactivate();
  } else if (o.lockstep) {
    const auto duration_ns = static_cast<std::int64_t>(std::llround(o.dry_run_s * 1e9));
    LockstepClock clock;
    SimulatedDamper plant(mrd::SpencerParams::Paper(), cfg.simulation, clock, cfg.period_ns);
    Loop loop(clock, plant, plant, controller, telemetry, cfg.period_ns);
    loop.Run(g_stop, duration_ns);
  } else {
    const auto duration_ns = static_cast<std::int64_t>(std::llround(o.dry_run_s * 1e9));
    MonotonicClock clock;
    SimulatedDamper plant(mrd::SpencerParams::Paper(), cfg.simulation, clock, cfg.period_ns);
    RunRealTime(cfg, plant, plant, controller, telemetry, duration_ns, &rt);
  }
  const TelemetrySnapshot s = telemetry.Read();
  PrintSummary(s, o, cfg, rt, table_name, devices);
  return s.safe ? kExitOk : kExitFailure;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!ParseArgs(argc, argv, &o)) return kExitBadInput;
  if (o.help) {
    std::fputs(kHelp, stdout);
    return kExitOk;
  }
  return Run(o);
}
