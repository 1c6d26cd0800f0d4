// mrd-hil — the hardware-in-the-loop harness: serves the reference damper over the same
// transports as hardware (local CAN bus / SocketCAN, Modbus TCP, Modbus RTU on a pty,
// simulated GPIO chip) to a firmware started separately (serve), or runs a scored scenario
// against a firmware child process (run; run.hpp).
#include <dirent.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "mrd/common/cli_checks.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/hil/ports/gpio_port.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/hil/run/run.hpp"
#include "mrd/hil/run/serve.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/hil/study/passive_baseline.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "report.hpp"
#include "study_command.hpp"
#include "sweep_command.hpp"
#include "table_check.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop.store(true); }
// `run`: the signal that asked it to stop (the run forwards it to the firmware child).
std::atomic<int> g_interrupt{0};
extern "C" void OnRunSignal(int sig) { g_interrupt.store(sig); }

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

// "TRANSPORT=ENDPOINT" -> a port; nullptr with *error.
// can_profile: the CAN ports' device profile (nullptr: the built-in mrd-native); modbus_profile:
// the Modbus ports' register map (nullptr: the built-in one).
std::unique_ptr<mrd::hil::PlantPort> MakePort(
    const std::string& spec, std::shared_ptr<const mrd::profile::CanProfile> can_profile,
    std::shared_ptr<const mrd::profile::ModbusProfile> modbus_profile, std::string* error) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == spec.size()) {
    *error = "--port '" + spec + "': expected TRANSPORT=ENDPOINT";
    return nullptr;
  }
  const std::string transport = spec.substr(0, eq), endpoint = spec.substr(eq + 1);
  std::unique_ptr<mrd::hil::PlantPort> port;
  if (transport == "can") {
    port = mrd::hil::MakeCanPort(endpoint, can_profile);
  } else if (transport == "modbus-tcp" || transport == "modbus-rtu") {
    const bool rtu = transport == "modbus-rtu";
    if (modbus_profile != nullptr) {
      port = mrd::hil::MakeModbusProfilePort(rtu, endpoint, modbus_profile);
    } else {
      port = rtu ? mrd::hil::MakeModbusRtuPort(endpoint) : mrd::hil::MakeModbusTcpPort(endpoint);
    }
  } else if (transport == "gpio") {
    mrd::hil::GpioPortConfig gpio;
    if (!mrd::hil::ParseGpioEndpoint(endpoint, &gpio, error)) return nullptr;
    port = mrd::hil::MakeGpioPort(gpio);
  } else {
    *error = "--port '" + spec + "': unknown transport '" + transport +
             "' (can, modbus-tcp, modbus-rtu, gpio)";
    return nullptr;
  }
  if (port == nullptr) *error = "--port '" + spec + "': transport not available in this build";
  return port;
}

// "START:END" seconds, 0 <= START < END -> the fault window; false with *error.
bool ParseFaultWindow(const std::string& spec, mrd::hil::ServeOptions* o, std::string* error) {
  const auto colon = spec.find(':');
  try {
    std::size_t n1 = 0, n2 = 0;
    if (colon == std::string::npos) throw std::invalid_argument(spec);
    const std::string a = spec.substr(0, colon), b = spec.substr(colon + 1);
    o->fault_start_s = std::stod(a, &n1);
    o->fault_end_s = std::stod(b, &n2);
    if (n1 != a.size() || n2 != b.size()) throw std::invalid_argument(spec);
  } catch (const std::exception&) {
    *error = "--fault-line '" + spec + "': expected START:END in seconds";
    return false;
  }
  if (!(o->fault_start_s >= 0.0 && o->fault_end_s > o->fault_start_s &&
        std::isfinite(o->fault_end_s))) {
    *error = "--fault-line '" + spec + "': needs 0 <= START < END";
    return false;
  }
  return true;
}

nlohmann::json ToJson(const mrd::hil::ServeResult& r) {
  nlohmann::json j;
  j["steps"] = r.steps;
  j["commands"] = r.commands;
  j["invariant_violations"] = r.invariant_violations;
  j["heartbeat_timeouts"] = r.heartbeat_timeouts;
  j["enabled_steps"] = r.enabled_steps;
  j["late_steps"] = r.late_steps;
  j["rms_force_n"] = r.rms_force_n;
  j["rms_tracking_error_n"] = r.rms_tracking_error_n;
  j["normalised_tracking_error"] = r.normalised_tracking_error;
  j["last_applied_v"] = r.last_applied_v;
  j["fault_steps"] = r.fault_steps;
  j["fault_driven_steps"] = r.fault_driven_steps;
  j["fault_reaction_steps"] = r.fault_reaction_steps;
  j["driven_after_fault_steps"] = r.driven_after_fault_steps;
  j["enable_falls"] = r.enable_falls;
  j["latency_us"] = {{"count", r.latency.count},
                     {"median", r.latency.median_us},
                     {"p99", r.latency.p99_us},
                     {"max", r.latency.max_us}};
  for (const auto& [name, c] : r.ports) {
    j["ports"][name] = {{"published", c.published},
                        {"received", c.received},
                        {"rejected", c.rejected},
                        {"refused", c.refused}};
  }
  return j;
}

std::string SelfDir() {
  char buf[4096];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return ".";
  buf[n] = '\0';
  std::string p(buf);
  const auto slash = p.find_last_of('/');
  return slash == std::string::npos ? "." : p.substr(0, slash);
}

// The scenarios shipped in hil/scenarios/ with their descriptions (for --help).
std::string ScenarioList() {
  std::string out = "Scenarios (" MRD_HIL_SCENARIO_DIR "):\n";
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(MRD_HIL_SCENARIO_DIR, ec)) {
    if (e.path().extension() == ".toml") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    mrd::hil::Scenario s;
    std::string error;
    const std::string name = std::filesystem::path(f).filename().string();
    out += "  " + name;
    if (mrd::hil::LoadScenario(f, &s, &error)) {
      out += std::string(name.size() < 30 ? 30 - name.size() : 1, ' ') + s.description;
    }
    out += "\n";
  }
  return out;
}

// Run, sweep: a Modbus device profile plays over Modbus TCP unless --transport says otherwise.
void DefaultTransport(const CLI::Option* transport_opt, mrd::hil::RunOptions* o) {
  if (transport_opt->count() == 0 && !o->profile.empty() &&
      mrd::profile::IsModbusProfileFile(o->profile)) {
    o->transport = "modbus-tcp";
  }
}

// Run, sweep: SIGTERM, SIGINT, SIGHUP set g_interrupt (the run stops, its firmware child gets
// the signal).
void CatchRunSignals(mrd::hil::RunOptions* o) {
  struct sigaction sa {};
  sa.sa_handler = OnRunSignal;
  sigemptyset(&sa.sa_mask);
  for (const int sig : {SIGTERM, SIGINT, SIGHUP}) sigaction(sig, &sa, nullptr);
  o->interrupt = &g_interrupt;
}

// run: the scenario (with --set and --passive-step), the firmware and table checked, the work
// directory (--out, else a temporary one: *temp) set. 0, or the exit code after the message.
int PrepareRun(const std::string& scenario_path, const std::vector<std::string>& sets,
               const std::string& out, double passive_step, mrd::hil::Scenario* scenario,
               mrd::hil::RunOptions* ro, std::string* temp) {
  mrd::hil::Scenario& s = *scenario;
  mrd::hil::RunOptions& o = *ro;
  std::string error;
  if (!mrd::hil::LoadScenario(scenario_path, sets, &s, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return kExitBadInput;
  }
  if (passive_step >= 0.0) {  // --passive-step
    if (!s.quarter_car) {
      std::fprintf(stderr, "error: --passive-step: %s is not a quarter car\n", s.path.c_str());
      return kExitBadInput;
    }
    if (passive_step > 0.0 && s.e_max / passive_step > 10000.0) {
      std::fprintf(stderr, "error: --passive-step %g: more than 10000 grid points over 0 .. %g V\n",
                   passive_step, s.e_max);
      return kExitBadInput;
    }
    s.passive_step_v = passive_step;
  }
  if (o.firmware.empty()) o.firmware = SelfDir() + "/mrd-firmware";
  if (access(o.firmware.c_str(), X_OK) != 0 && !o.attach) {
    std::fprintf(stderr, "error: %s: not an executable (give --firmware PATH)\n",
                 o.firmware.c_str());
    return kExitBadInput;
  }
  if (!mrd::hil::TableIsUsable(o.table.empty() ? s.table_file : o.table)) return kExitBadInput;
  std::error_code ec;
  if (!out.empty() && std::filesystem::exists(out, ec) && !std::filesystem::is_directory(out, ec)) {
    std::fprintf(stderr, "error: --out %s: exists and is not a directory\n",
                 mrd::Printable(out).c_str());
    return kExitBadInput;
  }
  if (!out.empty()) {
    o.work_dir = out;
    o.firmware_log = "firmware.mrdlog";  // beside trace.csv (mrd log info/export/plot)
  } else {
    char dir[] = "/tmp/mrd-hil-XXXXXX";
    if (mkdtemp(dir) == nullptr) {
      std::fprintf(stderr, "error: cannot create a temporary directory\n");
      return kExitFailure;
    }
    *temp = o.work_dir = dir;
  }
  o.keep_trace = true;
  if (o.attach && o.startup_timeout_s <= 0.0) o.startup_timeout_s = 120.0;  // start it by hand
  if (o.startup_timeout_s <= 0.0) o.startup_timeout_s = 10.0;
  return kExitOk;
}

// run, a quarter car with a passive grid: the best passive baseline (in process) into
// r->passive. 0, or 128 + the signal that interrupted it (the message printed).
int AddPassiveBaseline(const mrd::hil::Scenario& s, mrd::hil::RunResult* r) {
  mrd::hil::PassiveBaseline b;
  if (mrd::hil::ComputePassiveBaseline(s, *r, s.passive_step_v, &b,
                                       [](std::size_t i, std::size_t n) {
                                         if (i % 10 == 0 || i == n) {
                                           std::fprintf(stderr, "passive grid: %zu/%zu\n", i, n);
                                         }
                                         return g_interrupt.load() == 0;
                                       })) {
    r->passive = std::move(b);
  }
  if (const int sig = g_interrupt.load(); sig != 0) {
    std::fprintf(stderr, "error: interrupted by signal %d during the passive grid\n", sig);
    return 128 + sig;
  }
  return 0;
}

// run: the summary (JSON or text) on stdout, the files in --out (else the temporary
// directory removed); the exit code.
int ReportRun(const mrd::hil::Scenario& s, const mrd::hil::RunResult& r, const std::string& out,
              const std::string& temp, bool json, const std::string& table,
              const mrd::TimeWindow* window) {
  std::string error;
  nlohmann::json j = mrd::hil::SummaryJson(s, r);
  j["table"] = table;
  j["plant"] = mrd::hil::PlantLabel(s);
  if (!out.empty()) {
    std::string warning;
    if (!mrd::hil::WriteOutputs(out, j, r, window, &error, &warning)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return kExitFailure;
    }
    if (!warning.empty()) std::fprintf(stderr, "warning: %s\n", warning.c_str());
  } else {
    std::error_code ec;
    std::filesystem::remove_all(temp, ec);
  }
  if (json) {
    std::cout << j.dump(2) << std::endl;
  } else {
    std::cout << mrd::hil::SummaryText(s, r) << "  ran on: table " << table << ", plant "
              << mrd::hil::PlantLabel(s) << "\n";
    if (!out.empty() && r.corners) {
      std::cout << "  files: " << out
                << "/summary.json, corners.csv, firmware.toml, firmware.mrdlog (channel 0)\n";
    } else if (!out.empty())
      std::cout
          << "  files: " << out
          << "/summary.json, trace.csv, firmware.toml, firmware.mrdlog, tracking.png, command.png"
          << (r.ride ? ", ride.png" : "")
          << (r.passive ? ", comfort.png, psd.png, passive.dat, psd.dat" : "") << "\n";
  }
  if (!std::cout) return kExitFailure;
  return r.pass ? kExitOk : kExitFailure;
}

int RunCommand(const std::string& scenario_path, const std::vector<std::string>& sets,
               mrd::hil::RunOptions o, const std::string& out, bool json, double passive_step,
               const std::string& window_text, bool transport_given) {
  mrd::TimeWindow window;
  std::string why;
  if (!window_text.empty() && !mrd::ParseTimeWindow(window_text, &window, &why)) {
    std::fprintf(stderr, "error: --window %s\n", why.c_str());
    return kExitBadInput;
  }
  mrd::hil::Scenario s;
  std::string temp;
  if (const int rc = PrepareRun(scenario_path, sets, out, passive_step, &s, &o, &temp); rc != 0) {
    return rc;
  }
  // Four corners on Modbus maps ([channels] modbus_profiles) go over Modbus TCP unless
  // --transport says otherwise.
  if (!transport_given && s.channels.modbus()) o.transport = "modbus-tcp";
  mrd::hil::RunResult r;
  // SIGTERM, SIGINT, SIGHUP: the run stops, the firmware child gets the same signal and is
  // reaped, the temporary directory goes; exit 128 + the signal, as a shell reports it.
  CatchRunSignals(&o);
  std::string error;
  const int rc = mrd::hil::RunScenario(s, o, &r, &error);
  if (rc != 0) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    if (!r.firmware_stderr.empty()) std::fprintf(stderr, "firmware: %s", r.firmware_stderr.c_str());
    std::error_code ec;
    if (!temp.empty()) std::filesystem::remove_all(temp, ec);
    if (r.interrupted != 0) return 128 + r.interrupted;
    return rc == 2 ? kExitBadInput : kExitFailure;
  }
  if (r.ride && s.passive_step_v > 0.0) {  // the best passive baseline (in process)
    if (const int code = AddPassiveBaseline(s, &r); code != 0) {
      std::error_code ec;
      if (!temp.empty()) std::filesystem::remove_all(temp, ec);
      return code;
    }
  }
  const std::string table_path = o.table.empty() ? s.table_file : o.table;
  mrd::CoefficientTable table;
  if (!mrd::hil::LoadRunTable(table_path, &table)) return kExitBadInput;  // checked before
  return ReportRun(s, r, out, temp, json, mrd::hil::TableLabel(table_path, table),
                   window_text.empty() ? nullptr : &window);
}

// Lockstep speed over the local CAN bus and real-time wake-up jitter: the closed loop on the
// periodic excitation, force law, seconds of plant time each.
int BenchCommand(double seconds, mrd::hil::RunOptions o, bool json) {
  if (o.firmware.empty()) o.firmware = SelfDir() + "/mrd-firmware";
  if (access(o.firmware.c_str(), X_OK) != 0) {
    std::fprintf(stderr, "error: %s: not an executable (give --firmware PATH)\n",
                 o.firmware.c_str());
    return kExitBadInput;
  }
  if (!mrd::hil::TableIsUsable(o.table)) return kExitBadInput;
  mrd::hil::Scenario s;
  s.path = "(bench)";
  s.name = "bench";
  s.duration_s = seconds;
  nlohmann::json j;
  for (const char* clock : {"lockstep", "realtime"}) {
    char dir[] = "/tmp/mrd-hil-bench-XXXXXX";
    if (mkdtemp(dir) == nullptr) return kExitFailure;
    o.work_dir = dir;
    o.clock = clock;
    o.transport = "can";
    o.keep_trace = false;
    mrd::hil::RunResult r;
    std::string error;
    const int rc = mrd::hil::RunScenario(s, o, &r, &error);
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
    if (rc != 0) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return rc == 2 ? kExitBadInput : kExitFailure;
    }
    const auto stats = [](const mrd::hil::LatencyStats& l) {
      return nlohmann::json{
          {"count", l.count}, {"median", l.median_us}, {"p99", l.p99_us}, {"max", l.max_us}};
    };
    j[clock] = {{"plant_s", static_cast<double>(r.steps) * 1e-3},
                {"wall_s", r.wall_s},
                {"speed_x", r.speed_x},
                {"steps", r.steps},
                {"command_timeouts", r.command_timeouts},
                {"invariant_violations", r.invariant_violations},
                {"late_steps", r.late_steps},
                {"latency_us", stats(r.latency)}};
    if (std::string(clock) == "realtime") j[clock]["wake_jitter_us"] = stats(r.wake_jitter);
  }
  if (json) {
    std::cout << j.dump(2) << std::endl;
  } else {
    const auto& l = j["lockstep"];
    const auto& rt = j["realtime"];
    std::printf(
        "lockstep over the local CAN bus: %.3g s of plant time in %.3g s wall = %.3gx real "
        "time (%llu steps, %llu command timeouts)\n",
        l["plant_s"].get<double>(), l["wall_s"].get<double>(), l["speed_x"].get<double>(),
        l["steps"].get<unsigned long long>(), l["command_timeouts"].get<unsigned long long>());
    std::printf(
        "real time (1 kHz) wake-up jitter: median %.1f us, p99 %.1f us, max %.1f us "
        "(%llu late steps); sensor->command latency median %.1f us, p99 %.1f us\n",
        rt["wake_jitter_us"]["median"].get<double>(), rt["wake_jitter_us"]["p99"].get<double>(),
        rt["wake_jitter_us"]["max"].get<double>(), rt["late_steps"].get<unsigned long long>(),
        rt["latency_us"]["median"].get<double>(), rt["latency_us"]["p99"].get<double>());
  }
  return kExitOk;
}

// `serve`: its options, then the plant over the given ports until the duration or a signal.
struct ServeArgs {
  CLI::App* cmd = nullptr;
  std::vector<std::string> port_specs;
  mrd::hil::ServeOptions o;
  bool json = false;
  std::string fault_window;
  std::string profile;
  int rt_priority = 0;
};

void AddServe(CLI::App& app, ServeArgs* a) {
  auto* serve = a->cmd = app.add_subcommand(
      "serve",
      "Play the plant (sensors + current driver) over the given transports in real "
      "time (1 kHz) for a firmware started separately; print a summary.");
  mrd::hil::ServeOptions& o = a->o;
  serve
      ->add_option("--port", a->port_specs,
                   "TRANSPORT=ENDPOINT, repeatable: can=SOCKET_PATH|IFACE, "
                   "modbus-tcp=HOST:PORT, modbus-rtu=PTY_LINK_PATH, "
                   "gpio=SIM_CHIP_PATH[,KEY=VALUE...] (keys encoder_a=4 encoder_b=5 fault=6 "
                   "enable=17 heartbeat=18 counts_per_cm=400 fault_active_low=0)")
      ->required();
  serve->add_option("--duration", o.duration_s, "seconds to run (<= 0: until SIGINT/SIGTERM)")
      ->capture_default_str()
      ->check(mrd::cli::Finite);
  serve->add_option("--amplitude", o.excitation.amplitude_cm, "displacement amplitude [cm]")
      ->check(mrd::cli::FiniteRange(0.0, 100.0))
      ->capture_default_str();
  serve->add_option("--frequency", o.excitation.frequency_hz, "displacement frequency [Hz]")
      ->check(mrd::cli::FiniteRange(0.0, 1000.0))
      ->capture_default_str();
  serve->add_option("--demand", o.excitation.demand_amplitude_n, "force demand amplitude [N]")
      ->check(mrd::cli::FiniteRange(0.0, 1e6))
      ->capture_default_str();
  serve->add_option("--e-max", o.e_max, "highest admissible command [V]")
      ->check(mrd::cli::FiniteRange(0.0, 1e3))
      ->capture_default_str();
  serve
      ->add_option(
          "--heartbeat-timeout", o.heartbeat_timeout_s,
          "driver drops the coil to 0 V when heartbeats, once received, stop this long [s]")
      ->check(mrd::cli::FiniteRange(1e-3, 10.0))
      ->capture_default_str();
  serve->add_option("--fault-line", a->fault_window,
                    "START:END: assert the fault line (GPIO line, Modbus sensor block, CAN "
                    "DriverStatus overcurrent bit) from START to END seconds");
  serve->add_option("--profile", a->profile,
                    "device profile (docs/devices.md): a CAN profile for the can= ports (the "
                    "harness plays the driver and sensors in its messages) or a Modbus profile "
                    "for the modbus-tcp=/modbus-rtu= ports (the harness serves its map); "
                    "default: the built-in protocols");
  serve->add_flag("--json", a->json, "print the summary as JSON");
  serve
      ->add_option("--rt-priority", a->rt_priority,
                   "SCHED_FIFO priority (1-99) of the plant and its bus servers, so they "
                   "answer in time on a loaded host as a drive's own processor does; 0: normal "
                   "priority. Refused (no privilege): a warning, normal priority")
      ->check(mrd::cli::FiniteRange(0, 99))
      ->capture_default_str();
}

// serve --profile: a Modbus or CAN device profile (neither: the built-in protocols). false:
// the message printed.
bool LoadServeProfile(const std::string& path,
                      std::shared_ptr<const mrd::profile::CanProfile>* can_profile,
                      std::shared_ptr<const mrd::profile::ModbusProfile>* modbus_profile) {
  if (!path.empty() && mrd::profile::IsModbusProfileFile(path)) {
    auto p = std::make_shared<mrd::profile::ModbusProfile>();
    std::string error;
    if (!mrd::profile::LoadModbusProfile(path, p.get(), &error)) {
      std::fprintf(stderr, "error: --profile: %s\n", error.c_str());
      return false;
    }
    *modbus_profile = std::move(p);
  } else if (!path.empty()) {
    auto p = std::make_shared<mrd::profile::CanProfile>();
    std::string error;
    if (!mrd::profile::LoadCanProfile(path, p.get(), &error)) {
      std::fprintf(stderr, "error: --profile: %s\n", error.c_str());
      return false;
    }
    *can_profile = std::move(p);
  }
  return true;
}

// serve --rt-priority: SCHED_FIFO for this thread (the ports' server threads inherit it);
// true when granted.
bool SetRtPriority(int rt_priority) {
  bool sched_fifo = false;
  if (rt_priority > 0) {
    sched_param sp{};
    sp.sched_priority = rt_priority;
    const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    sched_fifo = err == 0;
    if (!sched_fifo)
      std::fprintf(stderr, "warning: --rt-priority %d refused (%s); serving at normal priority\n",
                   rt_priority, std::strerror(err));
  }
  return sched_fifo;
}

int ServeCommand(ServeArgs& a) {
  mrd::hil::ServeOptions& o = a.o;
  if (!a.fault_window.empty()) {
    std::string error;
    if (!ParseFaultWindow(a.fault_window, &o, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return kExitBadInput;
    }
  }
  // Before the ports open: a peer may signal as soon as it sees an endpoint (a socket file).
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGPIPE, SIG_IGN);
  std::shared_ptr<const mrd::profile::CanProfile> can_profile;
  std::shared_ptr<const mrd::profile::ModbusProfile> modbus_profile;
  if (!LoadServeProfile(a.profile, &can_profile, &modbus_profile)) return kExitBadInput;
  // Before the ports open: their server threads inherit the policy.
  const bool sched_fifo = SetRtPriority(a.rt_priority);
  std::vector<std::unique_ptr<mrd::hil::PlantPort>> ports;
  std::vector<mrd::hil::PlantPort*> raw;
  for (const auto& spec : a.port_specs) {
    std::string error;
    auto p = MakePort(spec, can_profile, modbus_profile, &error);
    if (p == nullptr) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return kExitBadInput;
    }
    if (!p->Open(&error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return kExitFailure;
    }
    raw.push_back(p.get());
    ports.push_back(std::move(p));
  }
  std::fprintf(stderr, "mrd-hil: serving on %zu port(s)\n", ports.size());
  const mrd::hil::ServeResult r = mrd::hil::Serve(o, raw, g_stop);
  for (auto& p : ports) p->Close();
  nlohmann::json j = ToJson(r);
  j["sched_fifo"] = sched_fifo;
  std::cout << j.dump(a.json ? 2 : -1) << std::endl;
  if (!std::cout) return kExitFailure;
  return kExitOk;
}

// `run`: its options (RunCommand runs it).
struct RunArgs {
  CLI::App* cmd = nullptr;
  std::string scenario_path, out_dir;
  mrd::hil::RunOptions ro;
  bool json = false;
  std::vector<std::string> sets;
  CLI::Option* transport_opt = nullptr;
  double passive_step = -1.0;
  std::string window;  // --window FROM:TO of the time plots
};

void AddRun(CLI::App& app, RunArgs* a) {
  auto* run = a->cmd = app.add_subcommand(
      "run",
      "Run a scenario against mrd-firmware (started as a child process, or --attach): "
      "plant, simulated driver, faults, scores. Exit 0 pass, 1 fail, 2 bad input.");
  mrd::hil::RunOptions& ro = a->ro;
  run->add_option("scenario", a->scenario_path, "scenario TOML (hil/scenarios/)")->required();
  run->add_option("--set", a->sets,
                  "KEY=VALUE, repeatable: override a scenario key (dotted path, e.g. "
                  "control.skyhook_gain=40, duration_s=5, control.law=passive-on) before the "
                  "scenario is read; VALUE typed as TOML, a bare word is a string")
      ->allow_extra_args(false);
  a->transport_opt = run->add_option("--transport", ro.transport,
                                     "can | modbus-tcp | modbus-rtu (default: can; "
                                     "modbus-tcp with a Modbus --profile or a scenario's "
                                     "[channels] modbus_profiles)")
                         ->capture_default_str();
  ro.clock = "lockstep";
  run->add_option("--clock", ro.clock,
                  "lockstep (time grants on the bus: deterministic, as fast as both sides "
                  "allow) | realtime (1 kHz wall clock: latency and jitter)");
  run->add_option("--table", ro.table, "coefficient table for the firmware (mrd export)");
  run->add_option("--profile", ro.profile,
                  "device profile (docs/devices.md): CAN (the harness plays the driver in its "
                  "messages), Modbus (a [modbus] map: the harness serves it) or CAN sensors "
                  "with a [pwm] set-point (read as a duty from a sysfs-ABI tree in the run's "
                  "directory, the enable from the GPIO chip); the firmware gets the same file "
                  "(default: mrd-native)");
  run->add_option("--can-log", ro.can_log,
                  "write every frame of the local CAN bus, both directions, to FILE in "
                  "candump -L format (stamped with the run's time: simulated in lockstep)");
  run->add_option("--sdo-refuse", ro.sdo_refuse,
                  "CANopen profiles (test hook): INDEX[:SUBINDEX]=ABORT_CODE, e.g. "
                  "0x6060=0x06090030: the simulated drive refuses that SDO download");
  run->add_option("--excitation", ro.excitation,
                  "CSV (header with x, v and the demand column, e.g. an `mrd generate` data "
                  "set) replacing the scenario's excitation");
  auto* fw_opt = run->add_option("--firmware", ro.firmware,
                                 "mrd-firmware to start (default: the one beside mrd-hil)");
  run->add_flag("--attach", ro.attach,
                "do not start the firmware: print the generated config and wait for one "
                "started by hand")
      ->excludes(fw_opt);
  run->add_option("--out", a->out_dir,
                  "write summary.json, trace.csv, firmware.toml, the firmware's per-period log "
                  "firmware.mrdlog (mrd log) and plots (gnuplot) here");
  run->add_option("--window", a->window,
                  "time plots in --out (tracking, command, ride): the window drawn sample by "
                  "sample, FROM:TO [s] (default: the first 5 s); the whole run's envelope is "
                  "drawn below it");
  ro.startup_timeout_s = 0.0;  // default: 10 s, 120 s with --attach
  run->add_option("--startup-timeout", ro.startup_timeout_s,
                  "seconds to wait for the firmware's first answer (default 10, 120 with "
                  "--attach); a firmware that never answers ends the run with an error")
      ->check(mrd::cli::FiniteRange(0.1, 3600.0));
  run->add_option("--command-timeout", ro.command_timeout_s,
                  "lockstep liveness: a firmware silent this long (wall clock) ends the run "
                  "with an error; a slow answer never changes the result [s]")
      ->check(mrd::cli::FiniteRange(0.1, 3600.0))
      ->capture_default_str();
  run->add_option("--can-interface", ro.can_interface,
                  "CAN: a SocketCAN interface (CAN_RAW with filters, e.g. vcan0) for harness and "
                  "firmware instead of the local frame bus");
  run->add_option("--gpio-sim", ro.gpio_sim,
                  "[gpio] scenarios: configfs directory of a live gpio-sim device (plant through "
                  "its sysfs pull/value, firmware through libgpiod) instead of a simulated chip "
                  "file");
  run->add_flag("--json", a->json, "print the summary as JSON");
  run->add_option("--passive-step", a->passive_step,
                  "quarter car: step of the best-passive grid over 0 .. E_max [V] (default: the "
                  "scenario's quarter_car.passive_step_v, 0.05); 0: no grid")
      ->check(mrd::cli::FiniteRange(0.0, 1e3));
}

// `bench`: its options (BenchCommand runs it).
struct BenchArgs {
  CLI::App* cmd = nullptr;
  double seconds = 10.0;
  mrd::hil::RunOptions o;
  bool json = false;
};

void AddBench(CLI::App& app, BenchArgs* a) {
  auto* bench = a->cmd = app.add_subcommand(
      "bench",
      "Benchmark: lockstep speed over the local CAN bus (x real time) and the real-time "
      "mode's wake-up jitter (median, p99, max), closed loop with mrd-firmware.");
  bench->add_option("--seconds", a->seconds, "plant seconds per mode")
      ->check(mrd::cli::FiniteRange(0.1, 3600.0))
      ->capture_default_str();
  bench->add_option("--firmware", a->o.firmware, "mrd-firmware (default: beside mrd-hil)");
  bench->add_option("--table", a->o.table, "coefficient table for the firmware");
  bench->add_flag("--json", a->json, "print the figures as JSON");
}

// `sweep`: its options; the defaults filled in after parsing (SweepCommand runs it).
struct SweepArgs {
  CLI::App* cmd = nullptr;
  std::string path, out;
  std::vector<std::string> sets;
  mrd::hil::RunOptions o;
  CLI::Option* transport_opt = nullptr;
};

void AddSweep(CLI::App& app, SweepArgs* a) {
  auto* sweep = a->cmd = app.add_subcommand(
      "sweep",
      "Run a scenario once per point of a grid of key values (lockstep, "
      "deterministic) and tabulate its scores: reachable tracking error, ride figures "
      "of a quarter car, pass/fail; writes sweep.csv and sweep.png (gnuplot).");
  sweep->add_option("scenario", a->path, "scenario TOML (hil/scenarios/)")->required();
  sweep
      ->add_option("--set", a->sets,
                   "KEY=FROM:TO:STEP (a swept key; FROM, FROM+STEP, ... up to TO) or "
                   "KEY=VALUE (fixed), repeatable; the grid is the product of the swept keys "
                   "(at most 1000 points)")
      ->required()
      ->allow_extra_args(false);
  sweep->add_option("--out", a->out,
                    "directory for sweep.csv, sweep.png, sweep.dat, sweep.gp (created; default "
                    "sweep-NAME, NAME the scenario file's stem)");
  a->transport_opt =
      sweep->add_option("--transport", a->o.transport, "can | modbus-tcp | modbus-rtu (as run)")
          ->capture_default_str();
  sweep->add_option("--table", a->o.table, "coefficient table for the firmware (mrd export)");
  sweep->add_option("--profile", a->o.profile, "device profile (as run)");
  sweep->add_option("--firmware", a->o.firmware,
                    "mrd-firmware to start (default: the one beside mrd-hil)");
}

int SweepMain(SweepArgs& a) {
  DefaultTransport(a.transport_opt, &a.o);
  if (a.o.firmware.empty()) a.o.firmware = SelfDir() + "/mrd-firmware";
  if (a.out.empty()) a.out = "sweep-" + std::filesystem::path(a.path).stem().string();
  CatchRunSignals(&a.o);
  return mrd::hil::SweepCommand(a.path, a.sets, a.o, a.out);
}

// `study`: its options (StudyCommand runs it).
CLI::App* AddStudy(CLI::App& app, mrd::hil::StudyOptions* study_o) {
  auto* study = app.add_subcommand(
      "study",
      "Comfort / road-holding study of a quarter-car or full-car scenario, in process and "
      "deterministic: per motion ratio x road class x speed the best passive constant voltage "
      "(grid "
      "over 0 .. E_max; full car: all four at one voltage, and front / rear apart) and each "
      "firmware law (its Controller at 1 kHz, one per corner); one table "
      "(text, CSV, JSON) and plots in --out (docs/study.md). Exit 0 done, 1 write "
      "error, 2 bad input.");
  study
      ->add_option("--scenario", study_o->scenario,
                   "quarter-car or full-car scenario TOML "
                   "(e.g. hil/scenarios/quarter-car-skyhook.toml, full-car-modal-skyhook.toml)")
      ->required();
  study->add_option("--classes", study_o->classes, "ISO 8608 road classes, comma-separated")
      ->capture_default_str();
  study->add_option("--speeds", study_o->speeds, "vehicle speeds [m/s], comma-separated")
      ->capture_default_str();
  study->add_option("--motion-ratios", study_o->motion_ratios,
                    "damper travel / wheel travel, each in [0.01, 1], comma-separated: the "
                    "same damper mounted on a different lever (default: the scenario's "
                    "quarter_car.motion_ratio)");
  study
      ->add_option("--laws", study_o->laws,
                   "firmware laws ([control] law names of the firmware's config), comma-"
                   "separated; NAME:KEY=VALUE[:KEY=VALUE] sets [control] keys of that law "
                   "(e.g. skyhook:skyhook_gain=40; default gain: the scenario's); full car: "
                   "also modal-skyhook[:heave=C:pitch=C:roll=C] (gains N s/m, N m s/rad), "
                   "default skyhook,groundhook,sh-add,modal-skyhook")
      ->capture_default_str();
  study
      ->add_option("--duration", study_o->duration_s,
                   "seconds per run (default: the scenario's duration_s)")
      ->check(mrd::cli::FiniteRange(0.0, 1e5));
  study
      ->add_option("--passive-step", study_o->passive_step_v,
                   "passive grid step over 0 .. E_max [V] (default: the scenario's "
                   "quarter_car.passive_step_v, 0.05)")
      ->check(mrd::cli::FiniteRange(0.0, 1e3));
  study->add_option("--out", study_o->out_dir,
                    "directory for study.txt, study.csv, study.json, study.png, "
                    "comfort-CLASS-SPEED[-rRATIO].png (default study-NAME, NAME the "
                    "scenario's stem)");
  study->add_flag("--json", study_o->json, "print the study as JSON instead of the table");
  return study;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mrd-hil: the reference MR damper served over the real protocols (HIL)."};
  app.require_subcommand(1);
  ServeArgs serve;
  AddServe(app, &serve);
  RunArgs run;
  AddRun(app, &run);
  BenchArgs bench;
  AddBench(app, &bench);
  SweepArgs sweep;
  AddSweep(app, &sweep);
  mrd::hil::StudyOptions study_o;
  CLI::App* study = AddStudy(app, &study_o);
  app.footer(ScenarioList() + "\n" + mrd::hil::ScenarioKeysHelp());
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  if (run.cmd->parsed()) {
    DefaultTransport(run.transport_opt, &run.ro);
    return RunCommand(run.scenario_path, run.sets, run.ro, run.out_dir, run.json, run.passive_step,
                      run.window, run.transport_opt->count() > 0);
  }
  if (sweep.cmd->parsed()) return SweepMain(sweep);
  if (bench.cmd->parsed()) return BenchCommand(bench.seconds, bench.o, bench.json);
  if (study->parsed()) {
    study_o.laws_given = study->get_option("--laws")->count() > 0;
    return mrd::hil::StudyCommand(study_o);
  }
  return ServeCommand(serve);
}
