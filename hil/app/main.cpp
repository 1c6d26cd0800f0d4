// mrd-hil — the hardware-in-the-loop harness: serves the reference damper over the same
// transports as hardware (local CAN bus / SocketCAN, Modbus TCP, Modbus RTU on a pty,
// simulated GPIO chip) to a firmware started separately.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

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
    port = mrd::hil::MakeGpioPort(endpoint);
  } else {
    *error = "--port '" + spec + "': unknown transport '" + transport +
             "' (can, modbus-tcp, modbus-rtu, gpio)";
    return nullptr;
  }
  if (port == nullptr) *error = "--port '" + spec + "': transport not available in this build";
  return port;
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
                    "modbus-tcp=HOST:PORT, modbus-rtu=PTY_LINK_PATH, gpio=SIM_CHIP_PATH")
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
  serve->add_flag("--json", json, "print the summary as JSON");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
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
