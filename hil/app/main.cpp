// mrd-hil — the hardware-in-the-loop harness: serves the reference damper over the same
// transports as hardware (local CAN bus / SocketCAN, Modbus TCP, Modbus RTU on a pty,
// simulated GPIO chip) to a firmware started separately.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "mrd/hil/gpio_port.hpp"
#include "mrd/hil/plant_port.hpp"
#include "mrd/hil/serve.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop.store(true); }

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

// "TRANSPORT=ENDPOINT" -> a port; nullptr with *error.
std::unique_ptr<mrd::hil::PlantPort> MakePort(const std::string& spec, std::string* error) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == spec.size()) {
    *error = "--port '" + spec + "': expected TRANSPORT=ENDPOINT";
    return nullptr;
  }
  const std::string transport = spec.substr(0, eq), endpoint = spec.substr(eq + 1);
  std::unique_ptr<mrd::hil::PlantPort> port;
  if (transport == "can") {
    port = mrd::hil::MakeCanPort(endpoint);
  } else if (transport == "modbus-tcp") {
    port = mrd::hil::MakeModbusTcpPort(endpoint);
  } else if (transport == "modbus-rtu") {
    port = mrd::hil::MakeModbusRtuPort(endpoint);
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
    j["ports"][name] = {{"published", c.published}, {"received", c.received},
                        {"rejected", c.rejected}};
  }
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mrd-hil: the reference MR damper served over the real protocols (HIL)."};
  app.require_subcommand(1);
  auto* serve = app.add_subcommand(
      "serve", "Play the plant (sensors + current driver) over the given transports in real "
               "time (1 kHz) for a firmware started separately; print a summary.");
  std::vector<std::string> port_specs;
  mrd::hil::ServeOptions o;
  bool json = false;
  serve->add_option("--port", port_specs,
                    "TRANSPORT=ENDPOINT, repeatable: can=SOCKET_PATH|IFACE, "
                    "modbus-tcp=HOST:PORT, modbus-rtu=PTY_LINK_PATH, "
                    "gpio=SIM_CHIP_PATH[,KEY=VALUE...] (keys encoder_a=4 encoder_b=5 fault=6 "
                    "enable=17 heartbeat=18 counts_per_cm=400 fault_active_low=0)")
      ->required();
  serve->add_option("--duration", o.duration_s, "seconds to run (<= 0: until SIGINT/SIGTERM)")
      ->capture_default_str();
  serve->add_option("--amplitude", o.excitation.amplitude_cm, "displacement amplitude [cm]")
      ->check(CLI::Range(0.0, 100.0))->capture_default_str();
  serve->add_option("--frequency", o.excitation.frequency_hz, "displacement frequency [Hz]")
      ->check(CLI::Range(0.0, 1000.0))->capture_default_str();
  serve->add_option("--demand", o.excitation.demand_amplitude_n, "force demand amplitude [N]")
      ->check(CLI::Range(0.0, 1e6))->capture_default_str();
  serve->add_option("--e-max", o.e_max, "highest admissible command [V]")
      ->check(CLI::Range(0.0, 1e3))->capture_default_str();
  serve->add_option("--heartbeat-timeout", o.heartbeat_timeout_s,
                    "driver drops the coil to 0 V without a heartbeat this long [s]")
      ->check(CLI::Range(1e-3, 10.0))->capture_default_str();
  std::string fault_window;
  serve->add_option("--fault-line", fault_window,
                    "START:END: assert the fault line (GPIO line, Modbus sensor block) from "
                    "START to END seconds");
  serve->add_flag("--json", json, "print the summary as JSON");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }

  if (!fault_window.empty()) {
    std::string error;
    if (!ParseFaultWindow(fault_window, &o, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return kExitBadInput;
    }
  }
  std::vector<std::unique_ptr<mrd::hil::PlantPort>> ports;
  std::vector<mrd::hil::PlantPort*> raw;
  for (const auto& spec : port_specs) {
    std::string error;
    auto p = MakePort(spec, &error);
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
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGPIPE, SIG_IGN);
  std::fprintf(stderr, "mrd-hil: serving on %zu port(s)\n", ports.size());
  const mrd::hil::ServeResult r = mrd::hil::Serve(o, raw, g_stop);
  for (auto& p : ports) p->Close();
  const nlohmann::json j = ToJson(r);
  std::cout << j.dump(json ? 2 : -1) << std::endl;
  if (!std::cout) return kExitFailure;
  return kExitOk;
}
