// mrd-canbus — the local frame bus relay (local_bus.hpp): a CAN bus stand-in over a UNIX
// SOCK_SEQPACKET socket for machines without AF_CAN. Runs until SIGINT/SIGTERM (or
// --duration), then prints its counters. docs/can_bus.md.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/local_bus.hpp"
#include "mrd/common/clock.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop.store(true); }

constexpr const char* kUsage =
    "usage: mrd-canbus --socket PATH [--duration SECONDS]\n"
    "  Relays every CAN frame a node sends to every other node connected to PATH\n"
    "  (firmware [can] local_bus = PATH; mrd-hil serve --port can=PATH).\n";

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  double duration_s = 0.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if ((a == "--socket" || a == "--duration") && i + 1 < argc) {
      const char* v = argv[++i];
      if (a == "--socket") {
        path = v;
      } else {
        char* end = nullptr;
        duration_s = std::strtod(v, &end);
        if (end == v || *end != '\0' || !(duration_s >= 0.0)) {
          std::fprintf(stderr, "error: --duration '%s': expected seconds >= 0\n", v);
          return 2;
        }
      }
      continue;
    }
    std::fprintf(stderr, "error: unknown or incomplete argument '%s'\n%s", a.c_str(), kUsage);
    return 2;
  }
  if (path.empty()) {
    std::fprintf(stderr, "error: --socket PATH is required\n%s", kUsage);
    return 2;
  }
  mrd::canbus::LocalBusRelay relay;
  std::string error;
  if (!relay.Open(path, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGPIPE, SIG_IGN);
  std::fprintf(stderr, "mrd-canbus: relaying on %s\n", path.c_str());
  const std::int64_t end_ns =
      duration_s > 0.0 ? mrd::common::MonotonicNs() + static_cast<std::int64_t>(duration_s * 1e9)
                       : 0;
  while (!g_stop.load() && (end_ns == 0 || mrd::common::MonotonicNs() < end_ns)) relay.Step(20);
  const mrd::canbus::RelayStats s = relay.stats();
  relay.Close();
  std::printf(
      "{\"nodes_joined\": %llu, \"nodes_left\": %llu, \"frames_in\": %llu, "
      "\"frames_out\": %llu, \"frames_dropped\": %llu, \"bad_packets\": %llu, "
      "\"nodes_refused\": %llu}\n",
      static_cast<unsigned long long>(s.nodes_joined),
      static_cast<unsigned long long>(s.nodes_left), static_cast<unsigned long long>(s.frames_in),
      static_cast<unsigned long long>(s.frames_out),
      static_cast<unsigned long long>(s.frames_dropped),
      static_cast<unsigned long long>(s.bad_packets),
      static_cast<unsigned long long>(s.nodes_refused));
  return 0;
}
