// mrd-hil run: the scenario loop (run.hpp). Scores and fault figures: run_scores.cpp.
#include "mrd/hil/run.hpp"

#include <linux/can.h>
#include <sys/prctl.h>
#include <sys/stat.h>

#include <csignal>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <functional>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>

#include "mrd/canbus/local_bus.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/hil/child.hpp"
#include "mrd/hil/excitation_profile.hpp"
#include "mrd/hil/model_plant.hpp"
#include "mrd/hil/plant.hpp"
#include "mrd/hil/structure_plant.hpp"
#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/modbus_profile.hpp"
#include "mrd/profile/pwm_profile.hpp"
#include "run_gpio.hpp"
#include "run_pwm.hpp"
#include "run_internal.hpp"

namespace mrd::hil {
namespace {

constexpr std::int64_t kPeriodNs = 1'000'000;

std::int64_t NowNs() { return common::MonotonicNs(); }
void SleepUntil(std::int64_t t_ns) { (void)common::SleepUntilNs(t_ns); }


std::string FormatSeconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g s", s);
  return buf;
}

// Output file suffix of the n-th firmware instance ("" for the first).
std::string Tag(int n) {
  char buf[16] = "";
  if (n > 0) std::snprintf(buf, sizeof buf, ".%d", n);
  return buf;
}

bool MakeDirs(const std::string& dir) {
  std::string partial;
  std::stringstream ss(dir);
  std::string part;
  if (!dir.empty() && dir[0] == '/') partial = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    partial += part + "/";
    if (mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST) return false;
  }
  return true;
}

std::unique_ptr<Plant> MakePlant(const Scenario& s, const SpencerParams& p, const Trace* trace) {
  if (s.plant_model != nullptr) {  // the model on the Spencer plant's motion (model_plant.hpp)
    Scenario motion = s;
    motion.plant_model = nullptr;
    return std::make_unique<ModelPlant>(s.plant_model, MakePlant(motion, p, trace));
  }
  if (s.quarter_car) return std::make_unique<QuarterCarAdapter>(p, s.car, s.road, 1e-3);
  if (s.structure) return std::make_unique<StructurePlant>(s.structure_setup, p, 1e-3, s.substeps);
  if (trace != nullptr) return std::make_unique<TracePlant>(p, *trace, 1e-3, s.substeps);
  PlantExcitation e = s.periodic;
  e.substeps = s.substeps;
  return std::make_unique<DamperPlantAdapter>(p, e, 1e-3);
}

RideFigures Figures(const RideMetrics& m) {
  return {m.count(), m.body_accel_rms(), m.travel_rms_cm(), m.tyre_load_rms_n(),
          m.max_travel_cm(), m.lift_off()};
}

SensorFault SensorFaultOf(FaultKind k) {
  switch (k) {
    case FaultKind::kDrop: return SensorFault::kDrop;
    case FaultKind::kCorrupt: return SensorFault::kCorrupt;
    case FaultKind::kStall: return SensorFault::kStall;
    case FaultKind::kOutOfRange: return SensorFault::kOutOfRange;
    case FaultKind::kNan: return SensorFault::kNan;
    default: return SensorFault::kNone;
  }
}

bool ReadFile(const std::string& path, std::string* out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::stringstream s;
  s << in.rdbuf();
  *out = s.str();
  return true;
}

// --can-log: frames in candump -L format, stamped with the run's time (lockstep: the step's
// simulated time; real time and before the first step: CLOCK_MONOTONIC).
struct CanLog {
  FILE* file = nullptr;
  std::int64_t t_ns = -1;
  bool Open(const std::string& path, std::string* error) {
    file = std::fopen(path.c_str(), "w");
    if (file == nullptr) *error = path + ": cannot write the CAN log (" + std::strerror(errno) + ")";
    return file != nullptr;
  }
  static void Write(void* context, const void* frame, bool /*in_process*/) {
    auto* log = static_cast<CanLog*>(context);
    can_frame f;
    std::memcpy(&f, frame, sizeof f);
    const std::int64_t t = log->t_ns >= 0 ? log->t_ns : NowNs();
    const bool extended = (f.can_id & CAN_EFF_FLAG) != 0;
    std::fprintf(log->file, "(%lld.%06lld) mrdbus ", static_cast<long long>(t / 1'000'000'000),
                 static_cast<long long>(t % 1'000'000'000 / 1000));
    std::fprintf(log->file, extended ? "%08X#" : "%03X#",
                 f.can_id & (extended ? CAN_EFF_MASK : CAN_SFF_MASK));
    for (int i = 0; i < f.len && i < 8; ++i) std::fprintf(log->file, "%02X", f.data[i]);
    std::fputc('\n', log->file);
  }
  CanLog() = default;
  CanLog(const CanLog&) = delete;
  CanLog& operator=(const CanLog&) = delete;
  ~CanLog() {
    if (file != nullptr) std::fclose(file);
  }
};

// The firmware's argv for this run.
std::vector<std::string> FirmwareArgv(const RunOptions& o, const std::string& config,
                                      const std::string& table, double duration_s) {
  // The harness is the plant: the demo table may drive it on any interface (vcan on a board).
  std::vector<std::string> argv = {o.firmware, "--config", config, "--json",
                                   "--allow-demo-table"};
  if (!table.empty()) {
    argv.push_back("--table");
    argv.push_back(table);
  }
  if (duration_s > 0.0) {
    std::ostringstream d;
    d.precision(17);
    d << duration_s;
    argv.push_back("--duration");
    argv.push_back(d.str());
  }
  return argv;
}

// A corrupt_table scenario: the firmware is offered a table with one flipped byte and must
// refuse it (exit 2) without ever driving the coil.
int RunCorruptTable(const Scenario& s, const RunOptions& o, PlantPort& port,
                    const std::function<void(std::int64_t)>& pump, const std::string& config,
                    RunResult* r, std::string* error) {
  std::string image;
  const std::string good = o.work_dir + "/table.bin";
  if (!o.table.empty()) {
    if (!ReadFile(o.table, &image)) {
      *error = o.table + ": cannot read";
      return 2;
    }
  } else {
    Child w;
    if (!w.Spawn({o.firmware, "--write-table", good}, o.work_dir + "/write_table.out",
                 o.work_dir + "/write_table.err", error)) {
      return 1;
    }
    if (w.Wait(10.0) != 0 || !ReadFile(good, &image)) {
      *error = "mrd-firmware --write-table failed";
      return 1;
    }
  }
  if (image.size() < 64) {
    *error = "table image too short";
    return 1;
  }
  image[image.size() / 2] = static_cast<char>(image[image.size() / 2] ^ 0x5A);
  const std::string bad = o.work_dir + "/corrupt_table.bin";
  std::ofstream(bad, std::ios::binary) << image;
  Child fw;
  const double dur = s.duration_s;
  if (!fw.Spawn(FirmwareArgv(o, config, bad, dur), o.work_dir + "/firmware.json",
                o.work_dir + "/firmware.err", error)) {
    return 1;
  }
  ++r->firmware_starts;
  // Listen meanwhile: a refusing firmware never sends a driving command.
  const std::int64_t until = NowNs() + static_cast<std::int64_t>(5e9);
  DriverInput in;
  while (fw.Alive() && NowNs() < until) {
    pump(2'000'000);
    DriverInput fresh;
    port.Poll(&fresh);
    if (fresh.has_command) {
      ++r->commands;
      if (!fresh.safe || fresh.volts != 0.0) ++r->driven_steps;
    }
  }
  r->firmware_exit = fw.Alive() ? fw.Stop(2.0) : fw.status();
  ReadFile(o.work_dir + "/firmware.err", &r->firmware_stderr);
  FaultResult fr;
  fr.fault = s.faults.front();
  fr.detection_required = false;
  const int expect = s.expect_firmware_exit.value_or(2);
  if (r->firmware_exit != expect) {
    fr.ok = false;
    fr.why = "firmware exit " + std::to_string(r->firmware_exit) + ", expected " +
             std::to_string(expect);
  } else if (r->driven_steps != 0) {
    fr.ok = false;
    fr.why = "the firmware drove the coil with a corrupt table";
  }
  r->faults.push_back(fr);
  return 0;
}

// --sdo-refuse "INDEX[:SUB]=ABORT" (C integer syntax: 0x6060, 24672).
struct SdoRefusal {
  int index = -1, subindex = -1;
  std::uint32_t code = 0;
};
bool ParseSdoRefusal(const std::string& text, SdoRefusal* r) {
  const auto eq = text.find('=');
  if (eq == std::string::npos) return false;
  const auto number = [](const std::string& t, unsigned long long max, unsigned long long* v) {
    char* end = nullptr;
    errno = 0;
    *v = std::strtoull(t.c_str(), &end, 0);
    return !t.empty() && errno == 0 && end != nullptr && *end == '\0' && *v <= max;
  };
  std::string object = text.substr(0, eq);
  unsigned long long index = 0, sub = 0, code = 0;
  const auto colon = object.find(':');
  if (colon != std::string::npos) {
    if (!number(object.substr(colon + 1), 255, &sub)) return false;
    r->subindex = static_cast<int>(sub);
    object.resize(colon);
  }
  if (!number(object, 0xFFFF, &index) || !number(text.substr(eq + 1), 0xFFFFFFFFULL, &code)) {
    return false;
  }
  r->index = static_cast<int>(index);
  r->code = static_cast<std::uint32_t>(code);
  return true;
}

}  // namespace

int RunScenario(const Scenario& scenario, const RunOptions& options, RunResult* r,
                std::string* error) {
  // The scenario's [firmware] table unless --table names one.
  RunOptions with_table = options;
  if (with_table.table.empty()) with_table.table = scenario.table_file;
  const RunOptions& o = with_table;
  // A profile with a PWM output (run_pwm.hpp): the driver's enable is a GPIO line, and so is the
  // heartbeat (the watchdog that drops the enable when the firmware stops).
  const bool pwm_profile = !o.profile.empty() && profile::ProfileHasPwm(o.profile);
  Scenario with_lines = scenario;
  if (pwm_profile) with_lines.gpio.enable = with_lines.gpio.heartbeat = true;
  const Scenario& s = with_lines;
  r->transport = o.transport;
  r->clock = !o.clock.empty() ? o.clock : "lockstep";
  const bool lockstep = r->clock == "lockstep";
  if (o.transport != "can" && o.transport != "modbus-tcp" && o.transport != "modbus-rtu") {
    *error = "--transport '" + o.transport + "': expected can, modbus-tcp or modbus-rtu";
    return 2;
  }
  if (r->clock != "lockstep" && r->clock != "realtime") {
    *error = "--clock '" + r->clock + "': expected lockstep or realtime";
    return 2;
  }
  if (!o.can_interface.empty() &&
      (o.transport != "can" || o.can_interface.find('/') != std::string::npos)) {
    *error = "--can-interface '" + o.can_interface + "': a SocketCAN interface name (no '/') "
             "with --transport can";
    return 2;
  }
  if (!o.gpio_sim.empty() && !s.gpio.any()) {
    *error = "--gpio-sim: scenario " + s.path + " routes nothing over GPIO (no [gpio])";
    return 2;
  }
  const bool corrupt_table =
      std::any_of(s.faults.begin(), s.faults.end(),
                  [](const Fault& f) { return f.kind == FaultKind::kCorruptTable; });
  if (corrupt_table && s.faults.size() != 1) {
    *error = s.path + ": a corrupt_table fault runs alone (the firmware never starts)";
    return 2;
  }
  if (o.attach && std::any_of(s.faults.begin(), s.faults.end(), [](const Fault& f) {
        return f.kind == FaultKind::kKillFirmware || f.kind == FaultKind::kCorruptTable;
      })) {
    *error = s.path + ": kill_firmware and corrupt_table faults need the harness to start the "
             "firmware (drop --attach)";
    return 2;
  }
  // Corrupt frames are a CAN fault; the Modbus port plays the others on its registers
  // (modbus_port.cpp).
  for (const Fault& f : s.faults) {
    if (f.kind == FaultKind::kCorrupt && o.transport != "can") {
      *error = s.path + ":" + std::to_string(f.line) + ": fault 'corrupt' is injected on CAN " +
               "frames only (not over " + o.transport + ")";
      return 2;
    }
  }
  // The CAN device profile: the harness plays the driver in its messages; the firmware gets
  // the same file.
  std::shared_ptr<const profile::CanProfile> can_profile;
  std::shared_ptr<const profile::ModbusProfile> modbus_profile;
  if (!o.profile.empty() && profile::IsModbusProfileFile(o.profile)) {
    // A Modbus device profile: the harness serves its map; the firmware gets the same file.
    if (o.transport == "can") {
      *error = "--profile " + o.profile + ": a Modbus device profile needs --transport "
               "modbus-tcp or modbus-rtu";
      return 2;
    }
    char resolved[PATH_MAX];
    auto p = std::make_shared<profile::ModbusProfile>();
    std::string why;
    if (realpath(o.profile.c_str(), resolved) == nullptr ||
        !profile::LoadModbusProfile(resolved, p.get(), &why)) {
      *error = "--profile: " + (why.empty() ? o.profile + ": " + std::strerror(errno) : why);
      return 2;
    }
    if (lockstep && !p->In(profile::CanIn::kGrant).mapped) {
      *error = "--profile " + o.profile + ": lockstep needs a 'grant' input in the profile's "
               "[modbus.inputs] (the simulation's time grant); or --clock realtime";
      return 2;
    }
    modbus_profile = p;
  } else if (!o.profile.empty()) {
    if (o.transport != "can") {
      *error = "--profile: a CAN device profile needs --transport can";
      return 2;
    }
    char resolved[PATH_MAX];
    auto p = std::make_shared<profile::CanProfile>();
    std::string why;
    if (realpath(o.profile.c_str(), resolved) == nullptr ||
        !profile::LoadCanProfile(resolved, p.get(), &why)) {
      *error = "--profile: " + (why.empty() ? o.profile + ": " + std::strerror(errno) : why);
      return 2;
    }
    if (lockstep && !p->inputs[static_cast<std::size_t>(profile::CanIn::kGrant)].mapped()) {
      *error = "--profile " + o.profile + ": lockstep needs a 'grant' input in the profile (the "
               "simulation's time grant, e.g. the native TimeGrant message); or --clock realtime";
      return 2;
    }
    if (pwm_profile && lockstep &&
        !p->outputs[static_cast<std::size_t>(profile::CanOut::kStatusSafe)].mapped() &&
        !p->outputs[static_cast<std::size_t>(profile::CanOut::kStatusCauses)].mapped()) {
      *error = "--profile " + o.profile + ": lockstep with a [pwm] output needs a firmware status "
               "message in the profile (status_safe or status_causes): the harness reads each "
               "tick's duty after it; or --clock realtime";
      return 2;
    }
    can_profile = p;
  }
  const bool canopen = can_profile != nullptr && can_profile->canopen.has_value();
  for (const Fault& f : s.faults) {
    if (f.kind == FaultKind::kDriveHeartbeatLoss && !canopen) {
      *error = s.path + ":" + std::to_string(f.line) + ": fault 'drive_heartbeat_loss' needs a "
               "CANopen device profile (--profile with a [canopen] section)";
      return 2;
    }
  }
  SdoRefusal refusal;
  if (!o.sdo_refuse.empty() && (!canopen || !ParseSdoRefusal(o.sdo_refuse, &refusal))) {
    *error = "--sdo-refuse '" + o.sdo_refuse + "': " +
             (canopen ? "expected INDEX[:SUBINDEX]=ABORT_CODE (e.g. 0x6060=0x06090030)"
                      : "needs a CANopen device profile (--profile with a [canopen] section)");
    return 2;
  }
  if (s.quarter_car && !o.excitation.empty()) {
    *error = "--excitation: " + s.path + " is a quarter car, excited by its [road]";
    return 2;
  }
  if (s.structure && !o.excitation.empty()) {
    *error = "--excitation: " + s.path + " is a structure, excited by its [structure] record";
    return 2;
  }
  const SpencerParams params = s.damper;  // preset, params file, overrides (scenario.cpp)
  Trace trace;
  const bool replaying = !s.quarter_car && s.excitation == ExcitationKind::kReplay;
  ReplayRun replay;  // the measured force (replay.hpp)
  const bool generated = !s.quarter_car && o.excitation.empty() &&
                         s.excitation == ExcitationKind::kProfile;
  const bool csv = !s.quarter_car && !generated &&
                   (s.excitation == ExcitationKind::kCsv || replaying || !o.excitation.empty());
  const std::string csv_path = o.excitation.empty() ? s.csv_file : o.excitation;
  if (replaying ? !LoadReplay(csv_path, s.law == "open-loop", s.demand_column, &trace, &replay,
                              error)
                : csv && !LoadTrace(csv_path, s.demand_column, &trace, error)) {
    return 2;
  }
  if (generated && !ProfileTrace(s.profile, s.profile_seed, params, &trace, error)) return 2;
  const Trace* tp = csv || generated ? &trace : nullptr;
  auto plant = MakePlant(s, params, tp);
  auto plant_off = MakePlant(s, params, tp);
  auto plant_on = MakePlant(s, params, tp);

  if (!MakeDirs(o.work_dir)) {
    *error = o.work_dir + ": cannot create (" + std::strerror(errno) + ")";
    return 1;
  }
  // The transport's endpoint. On CAN the harness owns the local frame bus, runs its relay
  // inline (pump below: forwarding happens in the harness's own waits, so a lockstep round costs
  // two wake-ups, harness -> firmware -> harness, instead of four through a relay thread) and is
  // an in-process node of it (no socket round trip of its own); the plant's node can go away
  // and come back (kill_plant).
  std::string endpoint;
  canbus::LocalBusRelay relay;
  CanLog can_log;  // --can-log: closed when the run returns
  std::unique_ptr<PlantPort> port;
  const bool can = o.transport == "can";
  const bool relay_bus = can && o.can_interface.empty();  // else SocketCAN (CAN_RAW)
  if (can && !relay_bus) {
    endpoint = o.can_interface;
    port = MakeCanPort(endpoint, can_profile);
  } else if (can) {
    endpoint = o.work_dir + "/canbus.sock";
    if (!relay.Open(endpoint, error)) return 1;
    port = MakeCanPortOnRelay(relay, can_profile);
    if (!o.can_log.empty() && !can_log.Open(o.can_log, error)) return 1;
    if (can_log.file != nullptr) relay.SetLog(&CanLog::Write, &can_log);
  } else if (o.transport == "modbus-rtu") {
    endpoint = o.work_dir + "/modbus-pty";
    port = modbus_profile != nullptr ? MakeModbusProfilePort(true, endpoint, modbus_profile)
                                     : MakeModbusRtuPort(endpoint);
  }
  if (o.transport == "modbus-tcp") {
    // A free port near a per-process base.
    const int base = 20000 + static_cast<int>(getpid() % 20000);
    for (int i = 0; i < 50 && port == nullptr; ++i) {
      endpoint = "127.0.0.1:" + std::to_string(base + i * 7);
      auto p = modbus_profile != nullptr ? MakeModbusProfilePort(false, endpoint, modbus_profile)
                                         : MakeModbusTcpPort(endpoint);
      std::string e;
      if (p != nullptr && p->Open(&e)) port = std::move(p);
    }
    if (port == nullptr) {
      *error = "modbus-tcp: no free port to listen on";
      return 1;
    }
  } else if (port == nullptr || !port->Open(error)) {
    if (port == nullptr) *error = o.transport + ": transport not available in this build";
    return 1;
  }
  bool port_open = true;
  port->SetLockstep(lockstep);
  if (refusal.index >= 0) port->RefuseSdo(refusal.index, refusal.subindex, refusal.code);
  // Waits up to timeout_ns for the firmware: on CAN by relaying the bus meanwhile (returns when
  // something moved), else on the port.
  const std::function<void(std::int64_t)> pump = [&](std::int64_t timeout_ns) {
    if (relay_bus) {
      relay.Step(static_cast<int>((timeout_ns + 999'999) / 1'000'000));
    } else if (timeout_ns > 0) {
      port->Wait(timeout_ns);
    }
  };
  const auto pump_for = [&](std::int64_t ns) {
    const std::int64_t until = NowNs() + ns;
    for (std::int64_t now = NowNs(); now < until; now = NowNs()) pump(until - now);
  };

  RunGpio gpio;  // the scenario's [gpio] lines (none without)
  std::string gpio_chip;
  if (!gpio.Open(s, o, &gpio_chip, error)) return 1;
  RunPwm pwm;  // the profile's PWM output (none without [pwm])
  std::string pwm_sysfs;
  if (pwm_profile && !pwm.Open(can_profile->path, o.work_dir, &pwm_sysfs, error)) return 2;
  std::string config =
      FirmwareConfigText(s, o.transport, lockstep, endpoint, gpio_chip, can_profile.get(),
                         modbus_profile.get(), pwm_sysfs);
  // The firmware's control socket in the run's folder (mrd-firmware ctl --socket
  // WORK_DIR/ctl.sock; docs/tuning.md), when the path fits a UNIX socket address.
  if (const std::string ctl = o.work_dir + "/ctl.sock";
      ctl.size() <= 107 && std::none_of(ctl.begin(), ctl.end(), [](char ch) {
        return ch == '"' || ch == '\\' || static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f;
      })) {
    config += "\n[ctl]\nsocket = \"" + ctl + "\"\n";
  }
  r->config_path = o.work_dir + "/firmware.toml";
  std::ofstream(r->config_path) << config
                                << (o.firmware_log.empty()
                                        ? std::string()
                                        : "\n[log]\npath = \"" + o.firmware_log + "\"\n");

  if (corrupt_table) {
    const int rc = RunCorruptTable(s, o, *port, pump, r->config_path, r, error);
    port->Close();
    r->ports.emplace_back(port->name(), port->counters());
    if (rc == 0) EvaluatePass(s, r);
    return rc;
  }

  const auto steps = static_cast<std::int64_t>(std::llround(s.duration_s / 1e-3));
  // Lockstep: the firmware stops itself at the run's end (its duration counts granted time).
  // One period more than the run: the firmware's shutdown (safe command block, enable low)
  // right after its last tick would race the harness reading that tick's command; the final
  // grant below gives it the extra tick.
  const double fw_duration = lockstep ? static_cast<double>(steps + 1) * 1e-3 : 0.0;
  Child fw;
  const auto spawn = [&](std::string* e) {
    if (o.attach) return true;
    const std::string tag = Tag(r->firmware_starts);
    if (!fw.Spawn(FirmwareArgv(o, r->config_path, o.table, fw_duration),
                  o.work_dir + "/firmware" + tag + ".json", o.work_dir + "/firmware" + tag + ".err",
                  e)) {
      return false;
    }
    if (r->firmware_starts > 0) port->PeerRestarted();
    ++r->firmware_starts;
    return true;
  };
  if (!spawn(error)) return 1;
  if (o.attach) {
    std::fprintf(stderr, "mrd-hil: waiting for a firmware started by hand:\n  mrd-firmware --config %s%s\n",
                 r->config_path.c_str(), lockstep ? " (lockstep: add --duration to stop it)" : "");
  }
  const auto firmware_alive = [&] { return o.attach || fw.Alive(); };
  const auto interrupted = [&] {
    return o.interrupt != nullptr ? o.interrupt->load(std::memory_order_relaxed) : 0;
  };
  // Ends the run early (error or signal): the firmware child stopped and reaped (the signal
  // forwarded), the ports closed; returns 1.
  const auto end_run = [&](const std::string& why, int sig) {
    *error = why;
    r->interrupted = sig;
    if (!o.attach) {
      r->firmware_exit = fw.Stop(2.0, sig != 0 ? sig : SIGTERM);
      ReadFile(o.work_dir + "/firmware" + Tag(r->firmware_starts - 1) + ".err",
               &r->firmware_stderr);
    }
    if (port_open) port->Close();
    gpio.Close();
    return 1;
  };
  const auto interrupt_text = [](int sig) {
    return std::string("interrupted by ") + strsignal(sig);
  };

  // A PWM duty is rounded to the nearest ns: E_max may come back up to half a step above.
  const double e_tolerance = pwm.active() ? 0.5 * pwm.QuantumVolts(s.e_max) + 1e-12 : 0.0;
  // Per-step state.
  DriverInput in;
  double set_point = 0.0;
  bool cmd_safe = true, enable = false, carries_enable = false;
  std::uint16_t causes = 0;
  std::uint64_t hb_count = 0;
  std::int64_t hb_step = std::numeric_limits<std::int64_t>::min() / 2;
  std::int64_t hb_ns = 0;
  bool hb_fresh_prev = false;
  bool awaiting_start = true;
  std::deque<SensorOutput> delayed;
  std::vector<double> latency_us, jitter_us;
  constexpr std::size_t kRing = 4096;
  std::vector<std::int64_t> published_ns(kRing, 0);
  std::vector<std::uint32_t> published_seq(kRing, 0);
  latency_us.reserve(static_cast<std::size_t>(steps) + 16);
  if (!lockstep) jitter_us.reserve(static_cast<std::size_t>(steps) + 16);
  if (o.keep_trace) r->trace.reserve(static_cast<std::size_t>(steps));
  const auto hb_timeout_steps = static_cast<std::int64_t>(std::llround(s.heartbeat_timeout_s / 1e-3));

  // Quarter car: ride figures of the run and of its passive twins after the settle time.
  RideMetrics ride, ride_off, ride_on;
  const bool score_ride = o.keep_trace && plant->Ride() != nullptr;
  // Structure: floor figures of the run and of its passive twins over every step.
  StructureMetrics floors, floors_off, floors_on;
  const bool score_floors = o.keep_trace && plant->Structure() != nullptr;

  PlantSample sample = plant->Sample();
  const auto publish = [&](SensorOutput out) {
    const std::int64_t t = NowNs();
    out.t_ns = t;
    published_seq[out.seq % kRing] = out.seq;
    published_ns[out.seq % kRing] = t;
    port->Publish(out);
  };

  // Real time: start when the firmware shows a sign of life (a heartbeat or command), with the
  // first sample on the bus meanwhile.
  if (!lockstep) {
    const std::int64_t until = NowNs() + static_cast<std::int64_t>(o.startup_timeout_s * 1e9);
    std::uint32_t seq = 0;
    bool failed = false;
    while (true) {
      SensorOutput out;
      out.sample = sample;
      out.seq = ++seq;
      publish(out);
      DriverInput fresh = in;
      port->Poll(&fresh);
      pwm.Poll(&fresh);  // the channel enabled: the firmware is up
      in = fresh;
      if (in.heartbeat_ns != 0 || in.has_command) break;
      if (const int sig = interrupted()) return end_run(interrupt_text(sig), sig);
      if (!firmware_alive() || NowNs() > until) {
        *error = firmware_alive() ? "the firmware did not answer within the start-up timeout"
                                  : "the firmware exited during start-up";
        failed = true;
        break;
      }
      pump_for(kPeriodNs);
    }
    if (failed) {
      r->firmware_exit = o.attach ? -1 : fw.Stop(2.0);
      ReadFile(o.work_dir + "/firmware.err", &r->firmware_stderr);
      return 1;
    }
    in.has_command = false;
    awaiting_start = false;
  }

  // Real time: 1 ns timer slack instead of the default 50 us (no privilege needed), so the
  // wake-up jitter measured is the scheduler's, not the slack's.
  if (!lockstep) prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  const std::int64_t wall0 = NowNs();
  std::int64_t deadline = wall0;
  std::uint32_t seq_base = 1000;  // real time: above the start-up publications
  for (std::int64_t k = 0; k < steps; ++k) {
    can_log.t_ns = lockstep ? k * kPeriodNs : -1;  // -1: stamp with CLOCK_MONOTONIC
    if (const int sig = interrupted()) return end_run(interrupt_text(sig), sig);
    // The fault schedule at step k.
    SensorFault sf = SensorFault::kNone;
    bool delay_active = false, implausible = false, plant_dead = false, fault_line = false;
    bool drive_hb_loss = false;
    int delay_periods = 0;
    for (const Fault& f : s.faults) {
      const auto k0 = static_cast<std::int64_t>(std::llround(f.at_s / 1e-3));
      const auto k1 = f.duration_s > 0.0
                          ? k0 + static_cast<std::int64_t>(std::llround(f.duration_s / 1e-3))
                          : steps;
      const bool active = k >= k0 && k < k1;
      if (f.kind == FaultKind::kKillFirmware) {
        if (k == k0 && !o.attach) fw.Kill();
        if (k == k1 && f.duration_s > 0.0 && !fw.Alive()) {
          // Restart: the previous instance's summary is kept under its own name.
          if (!spawn(error)) return 1;
          awaiting_start = true;
        }
      }
      if (!active) continue;
      if (SensorFaultOf(f.kind) != SensorFault::kNone && sf == SensorFault::kNone) {
        sf = SensorFaultOf(f.kind);
      }
      if (f.kind == FaultKind::kDelay) {
        delay_active = true;
        delay_periods = f.delay_periods;
      }
      if (f.kind == FaultKind::kImplausible) implausible = true;
      if (f.kind == FaultKind::kKillPlant) plant_dead = true;
      if (f.kind == FaultKind::kFaultLine) fault_line = true;
      if (f.kind == FaultKind::kDriveHeartbeatLoss) drive_hb_loss = true;
    }
    // Real time: the plant's bus node goes away. Lockstep: the harness is also the clock, so
    // time goes on (grants) while the plant's node is silent (no sensor data).
    if (plant_dead && port_open && !lockstep) {
      port->Close();
      port_open = false;
    } else if (!plant_dead && !port_open) {
      std::string e;
      port_open = port->Open(&e);
    }

    // Publish this step's sensors (and grant its tick).
    SensorOutput out;
    out.sample = sample;
    if (implausible) {
      out.sample.v = std::min(299.0, std::max(s.velocity_limit * 1.2, s.velocity_limit + 10.0));
    }
    out.seq = static_cast<std::uint32_t>(k + 1) + (lockstep ? 0 : seq_base);
    out.fault = sf;
    out.fault_line = fault_line;
    out.drive_heartbeat_loss = drive_hb_loss;
    if (!lockstep) {
      SleepUntil(deadline);
      const std::int64_t now = NowNs();
      jitter_us.push_back(static_cast<double>(now - deadline) * 1e-3);
      if (now - deadline > kPeriodNs) ++r->late_steps;
    }
    gpio.Publish(out, lockstep);  // lockstep: settled before the grant below
    if (port_open) {
      if (plant_dead) {
        // lockstep: silent plant, granted time (above)
      } else if (delay_active || !delayed.empty()) {
        delayed.push_back(out);
        while (!delayed.empty() &&
               (!delay_active || static_cast<std::int64_t>(out.seq - delayed.front().seq) >= delay_periods)) {
          publish(delayed.front());
          delayed.pop_front();
        }
      } else {
        publish(out);
      }
      if (lockstep) port->SendGrant((k + 1) * kPeriodNs);
    }
    pump(0);  // on its way to the firmware

    // Hear the firmware.
    DriverInput fresh = in;
    fresh.has_command = fresh.has_echo = fresh.has_status = fresh.has_safe = false;
    double command_age_ms = -1.0;
    if (lockstep) {
      // The tick's command and status (the generated config sends a status every period),
      // however long they take: simulated time never depends on wall time. Liveness is
      // separate: a firmware that exits is seen at once; one that stays silent for the
      // start-up or command timeout (wall clock) ends the run with an error.
      if (firmware_alive()) {
        const double wait_s = awaiting_start ? o.startup_timeout_s : o.command_timeout_s;
        const std::int64_t until = NowNs() + static_cast<std::int64_t>(wait_s * 1e9);
        std::int64_t resend = NowNs() + 50'000'000;
        while (true) {
          port->Poll(&fresh);
          // PWM: the tick's status frame says its duty is written (run_pwm.hpp).
          if (pwm.active() && fresh.has_status) pwm.Poll(&fresh);
          if (fresh.has_command && (fresh.has_status || !port->CarriesStatus())) break;
          if (!firmware_alive() && awaiting_start && !o.attach) {
            // Exited before its first command: it refused to start (its stderr says why).
            return end_run("the firmware exited during start-up (exit " +
                               std::to_string(fw.status()) + ")",
                           0);
          }
          if (!firmware_alive()) break;  // exited mid-step: no command for this step
          const std::int64_t now = NowNs();
          if (const int sig = interrupted()) return end_run(interrupt_text(sig), sig);
          if (now >= until) {
            return end_run(std::string(awaiting_start
                                           ? "no firmware answered within the start-up timeout ("
                                           : "the firmware stopped answering: no command within "
                                             "the command timeout (") +
                               FormatSeconds(wait_s) + ") at step " + std::to_string(k) +
                               (o.attach ? "" : "; it was stopped"),
                           0);
          }
          if (awaiting_start && now >= resend) {
            // The firmware may not be on the bus yet: offer the step again.
            if (!plant_dead) publish(out);
            port->SendGrant((k + 1) * kPeriodNs);
            resend = now + 50'000'000;
          }
          pump(std::min<std::int64_t>(until - now, 2'000'000));
        }
        if (!fresh.has_command) ++r->command_timeouts;
        else awaiting_start = false;
      }
    } else if (port_open) {
      pump(0);
      port->Poll(&fresh);
      pwm.Poll(&fresh);
    }
    gpio.Poll(&fresh);  // written in the same firmware tick as the command heard above
    if (fresh.has_command) {
      ++r->commands;
      set_point = fresh.volts;
      if (!std::isfinite(fresh.volts) || fresh.volts < 0.0 || fresh.volts > s.e_max + e_tolerance) {
        ++r->invariant_violations;
      }
      // The safe flag where the transport carries it (CAN); else the enable (Modbus).
      if (fresh.has_safe) {
        cmd_safe = fresh.safe;
      } else if (fresh.has_enable) {
        cmd_safe = !fresh.enable;
      }
      if (cmd_safe) ++r->safe_commands;
      if (fresh.has_echo) {
        const std::size_t slot = fresh.echo % kRing;
        if (published_seq[slot] == fresh.echo && published_ns[slot] != 0) {
          latency_us.push_back(static_cast<double>(fresh.command_ns - published_ns[slot]) * 1e-3);
          command_age_ms = lockstep ? 0.0 : latency_us.back() * 1e-3;
        }
      }
    }
    if (fresh.has_enable) {
      carries_enable = true;
      enable = fresh.enable;
    }
    if (fresh.has_status) causes = fresh.status_causes;
    if (fresh.heartbeats > hb_count) {
      hb_count = fresh.heartbeats;
      hb_step = k;
    }
    if (fresh.heartbeat_ns != 0) hb_ns = fresh.heartbeat_ns;
    in = fresh;

    // The simulated current driver: the set-point while enabled and the heartbeat is fresh
    // (in plant time under lockstep, wall time in real time); else the coil's safe 0 V.
    const bool hb_fresh = lockstep ? k - hb_step <= hb_timeout_steps
                                   : hb_ns != 0 && NowNs() - hb_ns <= static_cast<std::int64_t>(
                                                                          s.heartbeat_timeout_s * 1e9);
    if (hb_fresh_prev && !hb_fresh) ++r->heartbeat_timeouts;
    hb_fresh_prev = hb_fresh;
    const bool driven = (!carries_enable || enable) && hb_fresh;
    const double applied = driven && std::isfinite(set_point) ? std::clamp(set_point, 0.0, s.e_max) : 0.0;
    if (driven) ++r->driven_steps;

    // Step the plant and its passive twins.
    const double v_seen = sample.v;
    // What the damper can deliver on this step from its present state (0 V .. E_max).
    // (Scoring only: without a trace, e.g. the benchmark, neither the probes nor the passive
    // twins run.)
    double reach_a = 0.0, reach_b = 0.0, f_off = 0.0, f_on = 0.0;
    if (o.keep_trace) {
      reach_a = plant->Probe(0.0).force;
      reach_b = plant->Probe(s.e_max).force;
      f_off = plant_off->Step(0.0).force;
      f_on = plant_on->Step(s.e_max).force;
    }
    sample = plant->Step(applied);
    ++r->steps;
    if (score_ride && sample.t_s > s.ride_settle_s) {
      ride.Add(*plant->Ride());
      ride_off.Add(*plant_off->Ride());
      ride_on.Add(*plant_on->Ride());
    }
    if (score_floors) {
      floors.Add(*plant->Structure());
      floors_off.Add(*plant_off->Structure());
      floors_on.Add(*plant_on->Structure());
    }
    if (o.keep_trace) {
      const double lo = std::min(reach_a, reach_b), hi = std::max(reach_a, reach_b);
      r->trace.push_back({sample.t_s, sample.x, v_seen, sample.demand, sample.force, f_off, f_on,
                          set_point, applied, cmd_safe, driven,
                          sample.demand >= lo && sample.demand <= hi, causes});
      r->trace.back().command_age_ms = command_age_ms;
      if (score_ride) {
        r->trace.back().body_accel = plant->Ride()->body_accel;
        r->trace.back().body_accel_off = plant_off->Ride()->body_accel;
        r->trace.back().body_accel_on = plant_on->Ride()->body_accel;
      }
    }
    deadline += kPeriodNs;
  }
  const std::int64_t wall1 = NowNs();
  r->wall_s = static_cast<double>(wall1 - wall0) * 1e-9;
  r->speed_x = r->wall_s > 0.0 ? static_cast<double>(r->steps) * 1e-3 / r->wall_s : 0.0;
  r->latency = Summarise(std::move(latency_us));
  r->wake_jitter = Summarise(std::move(jitter_us));

  // Stop the firmware: in lockstep it ends by itself after its duration; else SIGTERM.
  if (!o.attach) {
    if (fw.Alive()) {
      if (lockstep) {
        // Its last tick may still wait for a grant: one more ends it.
        port->SendGrant((steps + 1) * kPeriodNs);
        const std::int64_t until = NowNs() + static_cast<std::int64_t>(o.command_timeout_s * 1e9);
        while (fw.Alive() && NowNs() < until) pump(2'000'000);
        if (fw.Alive()) fw.Stop(2.0);
      } else {
        fw.Stop(2.0);
      }
    }
    r->firmware_exit = fw.status();
    const std::string tag = Tag(r->firmware_starts - 1);
    ReadFile(o.work_dir + "/firmware" + tag + ".json", &r->firmware_json);
    ReadFile(o.work_dir + "/firmware" + tag + ".err", &r->firmware_stderr);
    const auto at = r->firmware_json.find("\"missed_grants\":");
    if (at != std::string::npos) {
      r->missed_grants = std::strtoull(r->firmware_json.c_str() + at + 16, nullptr, 10);
    }
  }
  if (port_open) port->Close();
  r->ports.emplace_back(port->name(), port->counters());
  if (score_ride) r->ride = RideScores{Figures(ride), Figures(ride_off), Figures(ride_on)};
  if (score_floors) {
    r->structure = StructureScores{floors.Figures(), floors_off.Figures(), floors_on.Figures()};
  }
  if (plant->Holds() != nullptr) r->plant_holds = *plant->Holds();
  if (gpio.active()) {
    gpio.Close();
    r->ports.emplace_back(gpio.name(), gpio.counters());
  }
  if (pwm.active()) {
    r->ports.emplace_back(pwm.name(), pwm.counters());
    pwm.Close();
  }
  ScoreRun(s, r);
  if (replaying && o.keep_trace) r->replay = ScoreReplay(r->trace, replay);
  EvaluatePass(s, r);
  return 0;
}

}  // namespace mrd::hil
