// mrd-firmware — MR damper controller: model + analytic inversion at a fixed period.
// Start-up (argument parsing, table and config loading, device configuration, real-time
// set-up) may allocate; the loop (Loop::Run) does not. With bus sections in the config the loop
// runs on the field devices (SocketCAN / local frame bus, Modbus, GPIO); with --dry-run it runs
// against the simulated Spencer damper. Maintenance commands (--check-*, --install-table) are in
// check.cpp; the JSON summary in summary_json.cpp.
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

#include "bus_channels.hpp"
#include "check.hpp"
#include "ctl_client.hpp"
#include "demo_table.hpp"
#include "dry_channels.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/common/lockstep_sched.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/io/devices.hpp"
#include "mrd/firmware/io/fieldbus_io.hpp"
#include "mrd/firmware/io/grant_clock.hpp"
#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/firmware/platform/params_server.hpp"
#include "mrd/firmware/platform/period_log.hpp"
#include "mrd/firmware/platform/runtime_params.hpp"
#include "mrd/firmware/platform/safe_state.hpp"
#include "mrd/firmware/platform/sd_notify.hpp"
#include "mrd/firmware/platform/table_file.hpp"
#include "mrd/firmware/platform/table_update.hpp"
#include "mrd/firmware/sim/simulated_damper.hpp"
#include "mrd/params/spencer_params_file.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/profile/pwm_profile.hpp"
#include "summary_json.hpp"
#include "wait_bus.hpp"

namespace {

using namespace mrd::firmware;            // NOLINT: application file
using namespace mrd::firmware::platform;  // NOLINT: application file

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

std::atomic<bool> g_stop{false};
std::atomic<bool> g_reload{false};  // SIGHUP: reload config and table (ReloadNow)

extern "C" void OnSignal(int) { g_stop.store(true); }
extern "C" void OnReload(int) { g_reload.store(true); }

// Every other terminating signal that can be caught stops the loop through its safe-state
// shutdown (SIGKILL and SIGSTOP cannot be caught); SIGHUP asks for a reload. Installed first
// thing in main.
void InstallStopHandlers() {
  struct sigaction sa {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  for (const int sig : {SIGINT, SIGTERM, SIGQUIT, SIGPIPE, SIGUSR1, SIGUSR2, SIGALRM, SIGVTALRM,
                        SIGPROF, SIGXCPU, SIGPWR, SIGSTKFLT}) {
    sigaction(sig, &sa, nullptr);
  }
  // A file grown past the file-size limit (RLIMIT_FSIZE, `ulimit -f`) is the log's write
  // error (EFBIG: the log stops, the loop keeps running), not a reason to stop the loop.
  signal(SIGXFSZ, SIG_IGN);
  struct sigaction hup {};
  hup.sa_handler = OnReload;
  sigemptyset(&hup.sa_mask);
  hup.sa_flags = SA_RESTART;
  sigaction(SIGHUP, &hup, nullptr);
}

// Longest dry run [s]: its duration in ns must fit std::int64_t (~292 years).
constexpr double kMaxDryRunS = 9.0e9;

// A dry run shorter than one period or too long to count in ns never ends (a duration <= 0
// means "no limit" to the loop): refused.
bool CheckDryRun(double seconds, std::int64_t period_ns) {
  if (seconds > kMaxDryRunS) {
    std::fprintf(stderr, "error: --dry-run %g s: beyond the longest run of %g s\n", seconds,
                 kMaxDryRunS);
    return false;
  }
  if (seconds * 1e9 < static_cast<double>(period_ns)) {
    std::fprintf(stderr, "error: --dry-run %g s: shorter than one period (%g us)\n", seconds,
                 static_cast<double>(period_ns) / 1e3);
    return false;
  }
  return true;
}

// Output goes to a file or pipe that may fail (e.g. /dev/full): a lost result is an error.
int FinishOutput(int status) {
  if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
    std::fprintf(stderr, "error: cannot write the result to standard output: %s\n",
                 std::strerror(errno));
    return status == kExitOk ? kExitFailure : status;
  }
  return status;
}

constexpr const char* kHelp =
    "mrd-firmware: MR damper controller (polynomial NARX model + analytic voltage inversion).\n"
    "\n"
    "Usage:\n"
    "  mrd-firmware [--table FILE] --config FILE.toml [--duration SECONDS] [--log FILE] [--json]\n"
    "  mrd-firmware [--table FILE] [--config FILE.toml] --dry-run SECONDS [--lockstep]\n"
    "               [--plant FILE] [--ignore-buses] [--log FILE] [--json]\n"
    "  mrd-firmware [--table FILE] --write-table OUT.bin\n"
    "  mrd-firmware --print-config-reference\n"
    "  mrd-firmware --check-config FILE.toml | --check-table FILE [--config F] [--rollback]\n"
    "  mrd-firmware --install-table NEW --to DEST [--config FILE.toml]\n"
    "  mrd-firmware --wait-for-bus FILE.toml [--timeout SECONDS]\n"
    "  mrd-firmware ctl [--socket PATH] list | get NAME | set NAME VALUE | save\n"
    "  mrd-firmware --help\n"
    "\n"
    "Options:\n"
    "  --table FILE        coefficient table (docs/table_format.md); default: the compiled-in\n"
    "                      table (firmware/include/mrd/firmware/builtin_table.hpp)\n"
    "  --config FILE       TOML configuration: period, E_max, safe state, control law, limits,\n"
    "                      and the buses ([can], [modbus], [gpio], [pwm]: where each signal comes\n"
    "                      from, where the command goes; keys: docs/firmware_config.md, or\n"
    "                      --print-config-reference)\n"
    "  --duration SECONDS  with bus sections: stop after this long (default: run until\n"
    "                      SIGINT/SIGTERM)\n"
    "  --dry-run SECONDS   run the control loop that long against the built-in simulated\n"
    "                      Spencer damper, then print the counters\n"
    "  --lockstep          dry run in simulated time (no sleeping; deterministic, fast)\n"
    "  --plant FILE        dry run: the simulated damper's Spencer parameters from FILE (the\n"
    "                      TOML of `mrd fit-spencer` and a HIL scenario's [plant] params;\n"
    "                      docs/plants.md) instead of the reference damper's\n"
    "  --ignore-buses      dry run with a config that has bus sections: leave them out and run\n"
    "                      everything else as configured (law, limits, envelope, log)\n"
    "  --json              print the counters as JSON\n"
    "  --log FILE          write the per-period log to FILE (docs/logging.md; read it with\n"
    "                      `mrd log info FILE`); overrides [log] path; default: [log] path,\n"
    "                      else no log\n"
    "  --write-table OUT   write the table image (e.g. the compiled-in one) and exit\n"
    "  --allow-demo-table  drive a real device (SocketCAN interface, GPIO chip, Modbus device)\n"
    "                      with the compiled-in demo table, a model of the reference damper,\n"
    "                      not of yours (refused without this flag)\n"
    "  --ctl-socket PATH   serve the control socket there (mode 0600; overrides [ctl]): list,\n"
    "                      read and change runtime parameters while the loop runs with\n"
    "                      mrd-firmware ctl (docs/tuning.md); a path a live firmware serves\n"
    "                      is refused, a stale socket file replaced\n"
    "  --wait-for-bus FILE wait until the SocketCAN interface of FILE's [can] section exists\n"
    "                      and is up, at most --timeout SECONDS (default 30), then exit 0;\n"
    "                      exit 1 naming the interface if it is not (the service's\n"
    "                      ExecStartPre; nothing to wait for without a [can] interface)\n"
    "  --print-config-reference  every config key with default, unit, range (Markdown)\n"
    "  --help              this text\n"
    "\n"
    "Real time: SCHED_FIFO and mlockall are requested when the config allows; without the\n"
    "privilege a warning is printed and the loop runs at normal priority.\n"
    "SIGINT, SIGTERM, SIGQUIT, SIGPIPE and the other catchable terminating signals stop the\n"
    "loop and leave the driver in the safe state; SIGXFSZ (a file past `ulimit -f`) is\n"
    "ignored: the log's write fails and stops the log, the loop keeps running.\n"
    "SIGHUP reloads the config and the table (the same paths): both are checked first (a bad\n"
    "one, or a changed key that needs a restart, is refused with the reason on stderr and the\n"
    "firmware keeps running on the old ones); otherwise a fresh controller takes over at a\n"
    "period boundary (model state reset; counted as reloads in the summary).\n"
    "Exit status: 0 ok, 1 failure, 2 bad input (arguments, config, refused table).\n";

struct Options {
  const char* table = nullptr;
  const char* config = nullptr;
  const char* write_table = nullptr;
  const char* ctl_socket = nullptr;
  const char* log = nullptr;
  const char* plant = nullptr;  // --plant FILE (dry run)
  double dry_run_s = -1.0;
  double duration_s = -1.0;
  bool lockstep = false;
  bool json = false;
  bool help = false;
  bool print_config_reference = false;
  bool allow_demo_table = false;
  bool ignore_buses = false;
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
    } else if (a == "--print-config-reference") {
      o->print_config_reference = true;
    } else if (a == "--table") {
      if (!value(&o->table)) return false;
    } else if (a == "--config") {
      if (!value(&o->config)) return false;
    } else if (a == "--ctl-socket") {
      if (!value(&o->ctl_socket)) return false;
    } else if (a == "--log") {
      if (!value(&o->log)) return false;
      if (*o->log == '\0') {
        std::fprintf(stderr, "error: --log needs a file name\n");
        return false;
      }
    } else if (a == "--plant") {
      if (!value(&o->plant)) return false;
    } else if (a == "--ignore-buses") {
      o->ignore_buses = true;
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
        std::fprintf(stderr, "error: --duration needs a number of seconds in (0, 1e9], got '%s'\n",
                     v);
        return false;
      }
    } else if (a == "--lockstep") {
      o->lockstep = true;
    } else if (a == "--allow-demo-table") {
      o->allow_demo_table = true;
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

// Per-device counters, a text line each, and the loop's faulted periods (faults[i] of
// devices[i]; none: a dry run).
void PrintDevices(const std::vector<std::unique_ptr<BusDevice>>& devices,
                  const std::vector<DeviceFaults>& faults) {
  const auto u = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
  for (std::size_t i = 0; i < devices.size(); ++i) {
    const BusDevice& d = *devices[i];
    const DeviceCounters c = d.counters();
    std::printf(
        "  %-8s rx %llu (rejected %llu), tx %llu (failed %llu), reconnects %llu, "
        "last error %s\n",
        d.name(), u(c.rx_ok), u(c.rx_rejected), u(c.tx_ok), u(c.tx_failed), u(c.reconnects),
        IoErrorName(c.last_error));
    if (i < faults.size()) {
      const DeviceFaults& f = faults[i];
      std::printf("  %-8s faulted periods: read %llu (last %s), write %llu (last %s)\n", "",
                  u(f.read_periods()), IoErrorName(f.last_read), u(f.write_periods()),
                  IoErrorName(f.last_write));
    }
  }
}

// Lockstep figures of a bus run (clock = "grant").
struct ClockInfo {
  const char* mode = "monotonic";
  std::uint64_t grants = 0;
  std::uint64_t missed = 0;  // 1: stopped because no grant came within grant_timeout_ms
};

// What a run leaves for the summary.
struct RunOutcome {
  Telemetry telemetry;
  RealTime rt;
  std::vector<std::unique_ptr<BusDevice>> devices;
  std::vector<DeviceFaults> faults;  // per device (FieldbusIo), after the run
  ClockInfo clock_info;
  bool grant_lost = false;                     // lockstep: the harness stopped granting time
  std::vector<SummaryInfo::Channel> channels;  // several channels: each one's (dry run)
};

// What both summaries report beyond the telemetry.
struct RunSummary {
  const Options& o;
  const FirmwareConfig& cfg;
  const RealTime& rt;
  const char* table_name;
  const std::vector<std::unique_ptr<BusDevice>>& devices;
  const std::vector<DeviceFaults>& faults;  // per device (empty: a dry run)
  const ClockInfo& ci;
  const RuntimeParams& params;
  const PeriodLogStats* log;  // nullptr: no log
  bool buses;
  double seconds;                                     // run length [s]
  double rms_model;                                   // [N]
  double rms_tracking;                                // [N]
  const std::vector<SummaryInfo::Channel>& channels;  // several channels (dry run); else empty
};

// The dry run's damper as the summary names it.
const char* DryRunPlantName(const Options& o) {
  return o.plant != nullptr ? o.plant : "reference damper (paper preset)";
}

// --json: one JSON object (summary_json.hpp).
void PrintSummaryJson(const TelemetrySnapshot& s, const RunSummary& r) {
  SummaryInfo info;
  info.mode = r.buses ? "bus" : (r.o.lockstep ? "lockstep" : "realtime");
  info.table = r.table_name;
  info.plant = r.buses ? "" : DryRunPlantName(r.o);
  info.law = ControlModeName(r.cfg.controller.law.mode);
  info.seconds = r.seconds;
  info.period_us = static_cast<double>(r.cfg.period_ns) / 1e3;
  info.sched_fifo = r.rt.sched_fifo;
  info.memory_locked = r.rt.memory_locked;
  info.rms_model_error_n = r.rms_model;
  info.rms_tracking_error_n = r.rms_tracking;
  for (std::size_t i = 0; i < r.devices.size(); ++i) {
    const BusDevice& d = *r.devices[i];
    info.devices.push_back(
        {d.name(), d.counters(), i < r.faults.size() ? r.faults[i] : DeviceFaults{}});
  }
  info.clock = r.ci.mode;
  info.grants = r.ci.grants;
  info.missed_grants = r.ci.missed;
  info.param_changes = r.params.changes();
  info.reloads = r.params.reloads();
  info.log = r.log;
  info.log_path = r.cfg.log.path.c_str();
  info.channels = r.channels;
  info.fault_policy = r.cfg.channels.fault_policy == FaultPolicy::kAll ? "all" : "channel";
  std::fputs(SummaryJson(s, info).c_str(), stdout);
}

// Several channels: a line per channel (the figures above are channel 0's).
void PrintChannels(const std::vector<SummaryInfo::Channel>& channels) {
  for (std::size_t i = 0; i < channels.size(); ++i) {
    const TelemetrySnapshot& c = channels[i].stats;
    std::printf(
        "  channel %zu:        table %s, %llu ticks, safe %llu periods (%llu entries), "
        "other_channel trips %llu, final %s\n",
        i, mrd::Printable(channels[i].table).c_str(), static_cast<unsigned long long>(c.ticks),
        static_cast<unsigned long long>(c.watchdog.safe_periods),
        static_cast<unsigned long long>(c.watchdog.entries),
        static_cast<unsigned long long>(
            c.watchdog.trips[static_cast<std::size_t>(FaultCause::kOtherChannel)]),
        c.safe ? "safe" : "NOT SAFE");
  }
}

// The text summary: a line per figure.
void PrintSummaryText(const TelemetrySnapshot& s, const RunSummary& r) {
  const Options& o = r.o;
  const FirmwareConfig& cfg = r.cfg;
  const RealTime& rt = r.rt;
  const char* table_name = r.table_name;
  const ClockInfo& ci = r.ci;
  const RuntimeParams& params = r.params;
  const PeriodLogStats* log = r.log;
  const bool buses = r.buses;
  const double seconds = r.seconds, rms_model = r.rms_model, rms_tracking = r.rms_tracking;
  const auto cause = [&](FaultCause c) { return static_cast<std::size_t>(c); };
  std::printf("mrd-firmware %s (%s, %.6g s, period %.6g us, law %s, table %s%s%s)\n",
              buses ? "run" : "dry run", buses ? "buses" : (o.lockstep ? "lockstep" : "real time"),
              seconds, static_cast<double>(cfg.period_ns) / 1e3,
              ControlModeName(cfg.controller.law.mode), table_name, buses ? "" : ", plant ",
              buses ? "" : mrd::Printable(DryRunPlantName(o)).c_str());
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
    std::printf(
        " %s %llu", FaultCauseName(static_cast<FaultCause>(i)),
        static_cast<unsigned long long>(s.watchdog.trips[cause(static_cast<FaultCause>(i))]));
  }
  std::printf("\n  unreachable:      %llu force demands saturated\n",
              static_cast<unsigned long long>(s.unreachable));
  std::printf("  passive demands:  %llu (0 N or against v: E_min)\n",
              static_cast<unsigned long long>(s.passive_demands));
  std::printf("  non-monotone:     %llu periods (model not monotone in E at the state)\n",
              static_cast<unsigned long long>(s.non_monotone));
  std::printf("  model resets:     %llu\n", static_cast<unsigned long long>(s.model_resets));
  std::printf("  envelope:         %llu periods with v/x held, %llu with the force held\n",
              static_cast<unsigned long long>(s.envelope_excursions),
              static_cast<unsigned long long>(s.force_excursions));
  std::printf("  last command:     %.6g V, model force %.6g N\n", s.last_command_v,
              s.model_force_n);
  std::printf("  parameters:       %llu changes, %llu reloads\n",
              static_cast<unsigned long long>(params.changes()),
              static_cast<unsigned long long>(params.reloads()));
  std::printf("  RMS errors:       model vs plant %.6g N, demand vs plant %.6g N\n", rms_model,
              rms_tracking);
  if (buses) {
    std::printf("  clock:            %s (grants %llu, missed %llu)\n", ci.mode,
                static_cast<unsigned long long>(ci.grants),
                static_cast<unsigned long long>(ci.missed));
    std::printf("  devices:\n");
  }
  PrintDevices(r.devices, r.faults);
  if (log != nullptr) {
    const auto u = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
    std::printf(
        "  log:              %s: %llu records written (%llu blocks, %u file%s), %llu "
        "dropped",
        cfg.log.path.c_str(), u(log->written), u(log->blocks), log->files,
        log->files == 1 ? "" : "s", u(log->dropped));
    if (log->failed) {
      std::printf("; STOPPED: %s (%llu records not written)", log->error.c_str(), u(log->lost));
    }
    std::printf("\n");
  }
  PrintChannels(r.channels);
  std::printf("  final state:      %s\n", s.safe ? "safe" : "NOT SAFE");
}

void PrintSummary(const TelemetrySnapshot& s, const Options& o, const FirmwareConfig& cfg,
                  const char* table_name, const RunOutcome& out, const RuntimeParams& params,
                  const PeriodLogStats* log) {
  const bool buses = !out.devices.empty();
  const double seconds =
      buses ? static_cast<double>(s.ticks) * static_cast<double>(cfg.period_ns) * 1e-9
            : o.dry_run_s;
  const double rms_model =
      s.force_samples > 0 ? std::sqrt(s.sum_sq_model_error / static_cast<double>(s.force_samples))
                          : 0.0;
  const double rms_tracking =
      s.tracking_samples > 0
          ? std::sqrt(s.sum_sq_tracking_error / static_cast<double>(s.tracking_samples))
          : 0.0;
  const RunSummary r{o,      cfg, out.rt, table_name, out.devices, out.faults,   out.clock_info,
                     params, log, buses,  seconds,    rms_model,   rms_tracking, out.channels};
  if (o.json) {
    PrintSummaryJson(s, r);
  } else {
    PrintSummaryText(s, r);
  }
}

// Runs the loop on CLOCK_MONOTONIC in a thread of its own (SCHED_FIFO and locked memory when
// the config asks and the system allows; warnings otherwise) until g_stop or duration_ns
// (<= 0: until g_stop). The calling thread reads the telemetry meanwhile.
void RunRealTime(const FirmwareConfig& cfg, Loop& loop, Telemetry& telemetry,
                 std::int64_t duration_ns, RealTime* rt, bool lockstep) {
  if (cfg.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      rt->memory_locked = true;
    } else {
      std::fprintf(stderr,
                   "warning: mlockall failed (%s); memory not locked, page faults may "
                   "delay the loop (needs CAP_IPC_LOCK or a higher RLIMIT_MEMLOCK)\n",
                   std::strerror(errno));
    }
  }
  std::atomic<bool> done{false};
  std::thread worker([&] {
    if (cfg.priority > 0) {
      sched_param sp{};
      sp.sched_priority = cfg.priority;
      const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
      if (err == 0) {
        rt->sched_fifo = true;
      } else {
        std::fprintf(stderr,
                     "warning: SCHED_FIFO priority %d refused (%s); running at normal "
                     "priority, expect jitter (needs CAP_SYS_NICE or an rtprio limit)\n",
                     cfg.priority, std::strerror(err));
      }
    } else if (lockstep) {
      // Lockstep with the harness: a period's frames read whole (lockstep_sched.hpp).
      (void)mrd::common::UseLockstepScheduling();
    }
    PrefaultStack();
    loop.Run(g_stop, duration_ns);
    done = true;
  });
  // The telemetry is read here while the loop runs (no locks, no stopping it); systemd's
  // watchdog is pinged from here while the tick counter advances.
  SystemdNotifier notifier;
  notifier.Send("READY=1");
  while (!done.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    notifier.Ping(std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::steady_clock::now().time_since_epoch())
                      .count(),
                  telemetry.Read().ticks);
  }
  notifier.Send("STOPPING=1");
  worker.join();
}

// One channel: the loop on source and driver (clock: CLOCK_MONOTONIC, or lockstep's).
void RunRealTime(const FirmwareConfig& cfg, SensorSource& source, CurrentDriver& driver,
                 Controller& controller, Telemetry& telemetry, std::int64_t duration_ns,
                 RealTime* rt, PeriodHook* hook, PeriodObserver* observer,
                 Clock* lockstep_clock = nullptr) {
  MonotonicClock monotonic;
  Clock& clock = lockstep_clock != nullptr ? *lockstep_clock : monotonic;
  Loop loop(clock, source, driver, controller, telemetry, cfg.period_ns);
  loop.SetHook(hook);
  loop.SetObserver(observer);
  RunRealTime(cfg, loop, telemetry, duration_ns, rt, lockstep_clock != nullptr);
}

// The command line's settings over the config's, at start-up and on every reload alike (they
// are not config changes): --ctl-socket, --log, --ignore-buses (a dry run without the buses).
void ApplyCommandLine(const Options& o, FirmwareConfig* cfg) {
  if (o.ctl_socket != nullptr) {
    cfg->ctl_socket = o.ctl_socket;
    cfg->ctl_enable = true;
  }
  if (o.log != nullptr) {
    cfg->log.path = o.log;
    cfg->log.enabled = true;
  }
  if (o.ignore_buses && o.dry_run_s > 0.0) cfg->io = IoConfig{};
}

// A device profile the reload would read differently from the one the devices run on (the
// file, its DBC or calibration changed): "" or what changed. The devices were built at
// start-up; a new map takes a restart.
std::string ChangedProfile(const FirmwareConfig& now, const FirmwareConfig& next) {
  const auto digest = [](const auto& p) { return p ? p->digest : std::uint64_t{0}; };
  const auto say = [](const std::string& section, const std::string& path) {
    return "the [" + section + "] device profile " + (path.empty() ? "(built-in)" : path) +
           " changed (the file, its DBC or calibration): the devices still run on the one "
           "they started with; restart the firmware to apply it";
  };
  if (now.io.can.enabled && digest(now.io.can.can_profile) != digest(next.io.can.can_profile)) {
    return say("can", next.io.can.profile);
  }
  if (now.io.modbus.enabled &&
      digest(now.io.modbus.modbus_profile) != digest(next.io.modbus.modbus_profile)) {
    return say("modbus", next.io.modbus.profile);
  }
  if (now.io.pwm.enabled && digest(now.io.pwm.pwm_profile) != digest(next.io.pwm.pwm_profile)) {
    return say("pwm", next.io.pwm.profile);
  }
  return "";
}

// The application's checks of a reload (as at start-up): "" or why it is refused.
std::string ReloadCheck(const Options& o, std::uint32_t served, bool buses,
                        const FirmwareConfig& next, const mrd::CoefficientTable& table,
                        const Controller& controller) {
  if (buses && controller.runtime().reads_displacement() &&
      (served & Bit(Input::kDisplacement)) == 0) {
    return "the model of the new table reads the displacement, but no bus serves input "
           "'displacement'";
  }
  // As at start-up: only a real device (not a loopback or pty simulation) needs the flag.
  if (const std::string device = buses ? RealDeviceOf(next.io) : std::string();
      !device.empty() && !o.allow_demo_table && IsDemoTable(table)) {
    return "the new table is the demo table, a model of the reference damper, not of yours "
           "(start with --allow-demo-table to drive " +
           device + " with it)";
  }
  return "";
}

// SIGHUP: reads the config and the table again from the paths the firmware started with and
// hands them to the loop (RuntimeParams::Reload); says on stderr what happened. Runs on the
// control thread, never the loop's.
void ReloadNow(const Options& o, RuntimeParams& params, const RuntimeParams::ReloadCheck& check) {
  const char* keep = "mrd-firmware: reload refused, still running on the old config and table:";
  FirmwareConfig next;
  std::string error;
  if (o.config != nullptr && !LoadConfigFile(o.config, &next, &error)) {
    std::fprintf(stderr, "%s %s\n", keep, error.c_str());
    return;
  }
  ApplyCommandLine(o, &next);
  if (const std::string why = ChangedProfile(params.config(), next); !why.empty()) {
    std::fprintf(stderr, "%s %s\n", keep, mrd::Printable(why).c_str());
    return;
  }
  mrd::CoefficientTable table = kBuiltinTable;
  if (o.table != nullptr) {
    std::string reason;
    const auto loaded = LoadTableFile(o.table, &reason);
    if (!loaded.ok()) {
      std::fprintf(stderr, "%s table %s %s: %s\n", keep, mrd::Printable(o.table).c_str(),
                   loaded.error() == mrd::Error::kIo ? "cannot be read" : "refused",
                   reason.c_str());
      return;
    }
    table = loaded.value();
  }
  next.controller.e_max = next.e_max.value_or(table.e_max);
  if (const SafeStateProof proof = ProveSafeState(next, next.controller.e_max);
      !proof.error.empty()) {
    std::fprintf(stderr, "%s %s\n", keep, mrd::Printable(proof.error).c_str());
    return;
  }
  const RuntimeParams::Result r = params.Reload(next, table, check);
  if (r.status != RuntimeParams::Status::kOk) {
    std::fprintf(stderr, "%s %s\n", keep, r.message.c_str());
    return;
  }
  std::fprintf(stderr,
               "mrd-firmware: reloaded config %s and table %s at period %llu "
               "(parameter version %u, reload %llu; model state reset)\n",
               o.config != nullptr ? mrd::Printable(o.config).c_str() : "(none)",
               o.table != nullptr ? mrd::Printable(o.table).c_str() : "compiled-in",
               static_cast<unsigned long long>(r.period), r.version,
               static_cast<unsigned long long>(params.reloads()));
}

// A start-up step's verdict: go on with the run, or end it with this exit status.
constexpr int kContinue = -1;

// The table to run on: --table FILE, or the compiled-in one. kContinue or kExitBadInput.
int LoadRunTable(const Options& o, mrd::CoefficientTable* table) {
  *table = kBuiltinTable;
  if (o.table == nullptr) return kContinue;
  std::string reason;
  const auto loaded = LoadTableFile(o.table, &reason);
  if (!loaded.ok()) {
    const std::string shown = mrd::Printable(o.table);
    if (loaded.error() == mrd::Error::kIo) {
      std::fprintf(stderr, "error: table %s: cannot read (%s)\n", shown.c_str(), reason.c_str());
    } else {
      std::fprintf(stderr, "error: table %s refused: %s\n", shown.c_str(), reason.c_str());
    }
    return kExitBadInput;
  }
  *table = loaded.value();
  return kContinue;
}

// --write-table OUT: the table as an image file (temporary, fsync, rename: OUT is the whole
// table or unchanged). The exit status.
int WriteTableOut(const char* path, const mrd::CoefficientTable& table) {
  if (const auto image = mrd::EncodeTable(table); !image.ok()) {
    std::fprintf(stderr, "error: table refused: %s\n", mrd::ErrorName(image.error()));
    return kExitBadInput;
  }
  const std::string why = WriteTableFile(path, table);
  if (!why.empty()) {
    std::fprintf(stderr, "error: %s (nothing written)\n", mrd::Printable(why).c_str());
    return kExitFailure;
  }
  return kExitOk;
}

// The config (--config FILE or the defaults) with E_max resolved against the table and the
// command line's --ctl-socket and --log applied. kContinue or kExitBadInput.
int LoadRunConfig(const Options& o, const mrd::CoefficientTable& table, FirmwareConfig* cfg) {
  if (o.config != nullptr) {
    std::string error;
    if (!LoadConfigFile(o.config, cfg, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return kExitBadInput;
    }
  }
  cfg->controller.e_max = cfg->e_max.value_or(table.e_max);
  if (o.ignore_buses && cfg->io.any()) {
    std::fprintf(stderr,
                 "mrd-firmware: --ignore-buses: dry run without the bus sections of %s "
                 "([can], [modbus], [gpio], [pwm])\n",
                 o.config != nullptr ? o.config : "the configuration");
  }
  // The safe state on the wire again, with the E_max of the table the loop runs on.
  if (const SafeStateProof proof = ProveSafeState(*cfg, cfg->controller.e_max);
      !proof.error.empty()) {
    std::fprintf(stderr, "error: %s: %s\n",
                 o.config != nullptr ? mrd::Printable(o.config).c_str() : "(default configuration)",
                 mrd::Printable(proof.error).c_str());
    return kExitBadInput;
  }
  ApplyCommandLine(o, cfg);
  return kContinue;
}

// Configures the controller; on a refusal says why (DescribeConfigureRefusal), naming the
// configuration file (or the defaults) and the table. kContinue or kExitBadInput.
int ConfigureController(const mrd::CoefficientTable& table, const char* table_name,
                        const char* config_path, const FirmwareConfig& cfg,
                        Controller* controller) {
  const ConfigureStatus configured = controller->Configure(table, cfg.controller);
  if (configured.ok()) return kContinue;
  if (configured.fault == ConfigureFault::kTable) {
    std::fprintf(stderr, "error: table %s refused: %s\n", table_name,
                 mrd::ErrorName(configured.error));
  } else {
    std::fprintf(
        stderr, "error: %s: refused with table %s: %s\n",
        config_path != nullptr ? config_path : "(default configuration)", table_name,
        mrd::firmware::platform::DescribeConfigureRefusal(configured, table, cfg.controller)
            .c_str());
  }
  return kExitBadInput;
}

// Buses configured (cfg.io.any()): the inputs the buses serve (Bit(Input)).
std::uint32_t ServedInputs(const FirmwareConfig& cfg) {
  return cfg.io.can.inputs | cfg.io.modbus.inputs | cfg.io.gpio.inputs;
}

// What to run follows from the options and the config: buses or a dry run (not both, not
// neither), no demo table on a real device, what the model reads served, a dry run's length.
// kContinue or kExitBadInput.
int CheckRunMode(const Options& o, const FirmwareConfig& cfg, const mrd::CoefficientTable& table,
                 const char* table_name, const Controller& controller) {
  const bool buses = cfg.io.any();
  if (buses && o.dry_run_s > 0.0) {
    std::fprintf(stderr,
                 "error: --dry-run runs the simulated damper; %s has bus sections "
                 "([can], [modbus], [gpio], [pwm]): drop --dry-run, use a config without them, "
                 "or pass --ignore-buses to dry-run the rest of it\n",
                 o.config);
    return kExitBadInput;
  }
  if (o.ignore_buses && o.dry_run_s <= 0.0) {
    std::fprintf(stderr, "error: --ignore-buses is for --dry-run\n");
    return kExitBadInput;
  }
  if (!buses && o.dry_run_s <= 0.0) {
    std::fprintf(stderr,
                 "error: nothing to run: give --config FILE with bus sections ([can], "
                 "[modbus], [gpio], [pwm]) or --dry-run SECONDS (see --help)\n");
    return kExitBadInput;
  }
  // Several channels on the bus: each channel's table is checked at its start (bus_channels).
  const bool per_channel = buses && cfg.channels.count > 1;
  if (const std::string device = buses ? RealDeviceOf(cfg.io) : std::string();
      !per_channel && !device.empty() && !o.allow_demo_table && IsDemoTable(table)) {
    std::fprintf(
        stderr,
        "error: table %s is the demo table, a model of the reference damper, not of "
        "yours: refusing to drive %s with it. Identify your damper (mrd identify, mrd "
        "export: see docs/guide/identify.md) and give its table with --table FILE, or pass "
        "--allow-demo-table\n",
        mrd::Printable(table_name).c_str(), mrd::Printable(device).c_str());
    return kExitBadInput;
  }
  if (buses && o.lockstep) {
    std::fprintf(stderr, "error: --lockstep is for --dry-run\n");
    return kExitBadInput;
  }
  if (buses && !per_channel && controller.runtime().reads_displacement() &&
      (ServedInputs(cfg) & Bit(Input::kDisplacement)) == 0) {
    std::fprintf(stderr,
                 "error: %s: the model of table %s reads the displacement, but no bus "
                 "serves input 'displacement'\n",
                 o.config, table_name);
    return kExitBadInput;
  }
  if (!buses && !CheckDryRun(o.dry_run_s, cfg.period_ns)) return kExitBadInput;
  return kContinue;
}

// The dry run's damper: --plant FILE, else the reference damper. kContinue or kExitBadInput
// ("error: FILE:LINE: reason").
int LoadDryRunPlant(const Options& o, mrd::SpencerParams* plant) {
  *plant = mrd::SpencerParams::Paper();
  if (o.plant == nullptr) return kContinue;
  if (o.dry_run_s <= 0.0) {
    std::fprintf(stderr, "error: --plant is for --dry-run (the simulated damper)\n");
    return kExitBadInput;
  }
  mrd::params::ParamsError e;
  if (!mrd::params::LoadSpencerParamsFile(o.plant, plant, &e)) {
    std::fprintf(stderr, "error: %s%s: %s\n", mrd::Printable(o.plant).c_str(),
                 e.line > 0 ? (":" + std::to_string(e.line)).c_str() : "",
                 mrd::Printable(e.reason).c_str());
    return kExitBadInput;
  }
  return kContinue;
}

// The per-period log of a run: started (ring allocated before mlockall) just before the loop
// runs, when the config or --log asks for it.
class RunLog {
 public:
  RunLog(const FirmwareConfig& cfg, const char* table_name) : cfg_(cfg), table_name_(table_name) {}
  void Start(const char* mode) {
    if (!cfg_.log.enabled || cfg_.log.path.empty()) return;
    log_.Start(cfg_.log, cfg_.period_ns,
               std::string("mrd-firmware ") + mode + ", table " + table_name_);
    observer_ = &log_;
  }
  PeriodObserver* observer() const { return observer_; }
  PeriodLog& log() { return log_; }

 private:
  const FirmwareConfig& cfg_;
  const char* table_name_;
  PeriodLog log_;
  PeriodObserver* observer_ = nullptr;
};

// What the loop leaves behind for the summary.

// Says that no grant came for grant_timeout (clock = "grant"); marks the run.
void GrantLost(const FirmwareConfig& cfg, RunOutcome* out) {
  std::fprintf(stderr,
               "error: no time grant for %.6g s (clock = \"grant\"): the harness "
               "is gone; stopped in the safe state\n",
               static_cast<double>(cfg.grant_timeout_ns) * 1e-9);
  out->grant_lost = true;
}

// Several channels over [can] (bus_channels.hpp) until the duration, a stop or (clock =
// "grant") the harness stops granting time. kContinue (ran) or the exit status.
int RunBusChannels(const Options& o, const FirmwareConfig& cfg, const mrd::CoefficientTable& table,
                   const char* table_name, RunLog& log, RunOutcome* out) {
  const std::int64_t duration_ns =
      o.duration_s > 0.0 ? static_cast<std::int64_t>(std::llround(o.duration_s * 1e9)) : 0;
  BusChannels bus({cfg, o.config, table, table_name, o.allow_demo_table, &g_stop}, &out->telemetry);
  if (const int rc = bus.Start(); rc != kContinue) return rc;
  const GrantClock* grants = bus.grant_clock();
  log.Start(grants != nullptr ? "bus run, clock grant, several channels"
                              : "bus run, clock monotonic, several channels");
  bus.loop().SetObserver(log.observer());
  RunRealTime(cfg, bus.loop(), out->telemetry, duration_ns, &out->rt, grants != nullptr);
  if (grants != nullptr) {
    out->clock_info = {"grant", grants->grants(), grants->gave_up() ? 1U : 0U};
    if (grants->gave_up()) GrantLost(cfg, out);
  }
  bus.Finish(&out->devices, &out->faults, &out->channels);
  return kContinue;
}

// The loop on the buses of cfg until the duration, SIGINT/SIGTERM or (clock = "grant") the
// harness stops granting time. kContinue (ran) or the exit status of a start-up failure.
int RunOnBuses(const Options& o, const FirmwareConfig& cfg, const mrd::CoefficientTable& table,
               const char* table_name, Controller& controller, RuntimeParams& params, RunLog& log,
               RunOutcome* out) {
  if (cfg.channels.count > 1) return RunBusChannels(o, cfg, table, table_name, log, out);
  std::string error;
  if (!MakeDevices(cfg.io, &out->devices, &error)) {
    std::fprintf(stderr, "error: %s: %s\n", o.config, error.c_str());
    return kExitBadInput;
  }
  auto& devices = out->devices;
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
  if (cfg.clock == LoopClock::kGrant) {
    // Lockstep with the HIL harness: the same loop on the time the CAN bus (or the Modbus
    // grant register) grants (duration in granted time).
    TimeGrantSource* grants = nullptr;
    for (auto& d : devices) {
      if (grants == nullptr) grants = d->grant_source();
    }
    if (grants == nullptr) {
      std::fprintf(stderr, "error: %s: clock = \"grant\" needs a [can] or [modbus] device\n",
                   o.config);
      for (auto& d : devices) d->Deactivate();
      return kExitBadInput;
    }
    GrantClock clock(*grants, cfg.grant_timeout_ns, &g_stop);
    log.Start("bus run, clock grant");
    RunRealTime(cfg, io, io, controller, out->telemetry, duration_ns, &out->rt, &params,
                log.observer(), &clock);
    out->clock_info = {"grant", clock.grants(), clock.gave_up() ? 1U : 0U};
    if (clock.gave_up()) GrantLost(cfg, out);
  } else {
    log.Start("bus run, clock monotonic");
    RunRealTime(cfg, io, io, controller, out->telemetry, duration_ns, &out->rt, &params,
                log.observer());
  }
  for (std::size_t i = 0; i < io.size(); ++i) out->faults.push_back(io.faults(i));
  for (auto& d : devices) d->Deactivate();
  return kContinue;
}

// The loop on the simulated damper for --dry-run seconds: lockstep (simulated time, as fast
// as it goes) or in real time; several channels (dry_channels.hpp) with [channels] count > 1.
// kContinue, or kExitBadInput when a channel's table is refused.
int RunDry(const Options& o, const FirmwareConfig& cfg, const mrd::SpencerParams& damper,
           const mrd::CoefficientTable& table, const char* table_name, Controller& controller,
           RuntimeParams& params, RunLog& log, RunOutcome* out) {
  const auto duration_ns = static_cast<std::int64_t>(std::llround(o.dry_run_s * 1e9));
  if (cfg.channels.count > 1) {
    log.Start(o.lockstep ? "dry run, lockstep, several channels" : "dry run, several channels");
    const DryChannelsRun run{cfg,         table,      table_name,    damper,
                             duration_ns, o.lockstep, log.observer()};
    const std::string why = RunDryChannels(run, g_stop, &out->telemetry, &out->channels);
    if (why.empty()) return kContinue;
    std::fprintf(stderr, "error: %s\n", mrd::Printable(why).c_str());
    return kExitBadInput;
  }
  if (o.lockstep) {
    LockstepClock clock;
    SimulatedDamper plant(damper, cfg.simulation, clock, cfg.period_ns);
    Loop loop(clock, plant, plant, controller, out->telemetry, cfg.period_ns);
    loop.SetHook(&params);
    log.Start("dry run, lockstep");
    loop.SetObserver(log.observer());
    loop.Run(g_stop, duration_ns);
  } else {
    MonotonicClock clock;
    SimulatedDamper plant(damper, cfg.simulation, clock, cfg.period_ns);
    log.Start("dry run, real time");
    RunRealTime(cfg, plant, plant, controller, out->telemetry, duration_ns, &out->rt, &params,
                log.observer());
  }
  return kContinue;
}

int Run(const Options& o) {
  mrd::CoefficientTable table;
  const char* table_name = o.table != nullptr ? o.table : "compiled-in";
  if (const int rc = LoadRunTable(o, &table); rc != kContinue) return rc;
  if (o.write_table != nullptr) return WriteTableOut(o.write_table, table);

  FirmwareConfig cfg;
  if (const int rc = LoadRunConfig(o, table, &cfg); rc != kContinue) return rc;
  Controller controller;
  if (const int rc = ConfigureController(table, table_name, o.config, cfg, &controller);
      rc != kContinue) {
    return rc;
  }
  if (const int rc = CheckRunMode(o, cfg, table, table_name, controller); rc != kContinue) {
    return rc;
  }
  mrd::SpencerParams plant;
  if (const int rc = LoadDryRunPlant(o, &plant); rc != kContinue) return rc;
  if (const std::string why = CheckLogPath(cfg.log); !why.empty()) {
    std::fprintf(stderr, "error: %s\n", mrd::Printable(why).c_str());
    return kExitBadInput;
  }
  RunLog log(cfg, table_name);
  // Runtime parameters, the control socket and the SIGHUP reload watch (a thread of their
  // own, off the loop's; docs/tuning.md).
  RuntimeParams params(table, cfg);
  ParamsServer server(params, o.config != nullptr ? o.config : "");
  if (cfg.ctl_enable) {
    const std::string path = !cfg.ctl_socket.empty() ? cfg.ctl_socket : DefaultCtlSocket();
    const std::string why = server.Open(path);
    if (!why.empty()) {
      std::fprintf(stderr, "error: %s\n", why.c_str());
      return kExitBadInput;
    }
  }
  const bool buses = cfg.io.any();
  const RuntimeParams::ReloadCheck reload_check =
      [&o, served = ServedInputs(cfg), buses](const FirmwareConfig& next,
                                              const mrd::CoefficientTable& t, const Controller& c) {
        return ReloadCheck(o, served, buses, next, t, c);
      };
  server.Start([&, several = cfg.channels.count > 1] {
    if (!g_reload.exchange(false)) return;
    if (several) {  // each channel's controller runs on the config it started with
      std::fprintf(stderr,
                   "mrd-firmware: reload not applied: several channels ([channels] count > 1) "
                   "run on the config and tables they started with; restart to apply a change\n");
      return;
    }
    ReloadNow(o, params, reload_check);
  });

  RunOutcome out;
  if (buses) {
    if (const int rc = RunOnBuses(o, cfg, table, table_name, controller, params, log, &out);
        rc != kContinue) {
      return rc;
    }
  } else {
    if (const int rc = RunDry(o, cfg, plant, table, table_name, controller, params, log, &out);
        rc != kContinue) {
      return rc;
    }
  }
  params.LoopEnded();
  server.Stop();
  log.log().Stop();
  const PeriodLogStats log_stats = log.log().stats();
  const TelemetrySnapshot s = out.telemetry.Read();
  PrintSummary(s, o, params.config(), table_name, out, params,
               log.observer() != nullptr ? &log_stats : nullptr);
  bool all_safe = s.safe;
  for (const SummaryInfo::Channel& c : out.channels) all_safe = all_safe && c.stats.safe;
  return all_safe && !out.grant_lost ? kExitOk : kExitFailure;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && std::strcmp(argv[1], "ctl") == 0) {
    return FinishOutput(mrd::firmware::RunCtl(argc - 1, argv + 1));
  }
  if (argc >= 2 && std::strcmp(argv[1], "--wait-for-bus") == 0) {
    return FinishOutput(mrd::firmware::RunWaitForBus(argc, argv));
  }
  if (const int status = RunMaintenance(argc, argv); status >= 0) return status;
  InstallStopHandlers();
  Options o;
  if (!ParseArgs(argc, argv, &o)) return kExitBadInput;
  if (o.help) {
    std::fputs(kHelp, stdout);
    return FinishOutput(kExitOk);
  }
  if (o.print_config_reference) {
    std::fputs(ConfigReference().c_str(), stdout);
    return FinishOutput(kExitOk);
  }
  return FinishOutput(Run(o));
}
