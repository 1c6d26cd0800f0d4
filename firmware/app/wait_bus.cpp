#include "wait_bus.hpp"

#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "mrd/common/input_file.hpp"
#include "mrd/firmware/platform/config.hpp"

namespace mrd::firmware {
namespace {

constexpr int kOk = 0;
constexpr int kNotUp = 1;
constexpr int kBadInput = 2;

// True when the network interface exists and is administratively up (IFF_UP).
bool InterfaceUp(const std::string& name) {
  if (name.size() >= IFNAMSIZ || if_nametoindex(name.c_str()) == 0) return false;
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return true;  // it exists; the flags cannot be read here: let the firmware try
  ifreq req{};
  std::memcpy(req.ifr_name, name.c_str(), name.size());
  const bool up = ioctl(fd, SIOCGIFFLAGS, &req) == 0 && (req.ifr_flags & IFF_UP) != 0;
  close(fd);
  return up;
}

}  // namespace

int RunWaitForBus(int argc, char** argv) {
  const char* usage = "usage: mrd-firmware --wait-for-bus FILE.toml [--timeout SECONDS]\n";
  if (argc < 3) {
    std::fprintf(stderr, "error: --wait-for-bus needs a config file\n%s", usage);
    return kBadInput;
  }
  double timeout_s = 30.0;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--timeout" && i + 1 < argc) {
      char* end = nullptr;
      timeout_s = std::strtod(argv[++i], &end);
      if (end == argv[i] || *end != '\0' || !std::isfinite(timeout_s) || timeout_s < 0.0 ||
          timeout_s > 3600.0) {
        std::fprintf(stderr, "error: --timeout needs seconds in [0, 3600], got '%s'\n",
                     Printable(argv[i]).c_str());
        return kBadInput;
      }
    } else {
      std::fprintf(stderr, "error: unexpected argument '%s' for --wait-for-bus\n%s",
                   Printable(a).c_str(), usage);
      return kBadInput;
    }
  }
  platform::FirmwareConfig config;
  std::string error;
  if (!platform::LoadConfigFile(argv[2], &config, &error)) {
    std::fprintf(stderr, "error: %s\n", Printable(error, 4 * kMaxEchoChars).c_str());
    return kBadInput;
  }
  const std::string& name = config.io.can.interface;
  if (!config.io.can.enabled || name.empty()) {
    std::printf("%s: no CAN interface to wait for\n", Printable(argv[2]).c_str());
    return kOk;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const auto waited = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  bool said = false;
  while (!InterfaceUp(name)) {
    if (waited() >= timeout_s) {
      std::fprintf(stderr,
                   "error: CAN interface %s is not up after %g s (%s); bring it up (ip link set "
                   "%s up type can bitrate ...) or check its driver; the service retries\n",
                   Printable(name).c_str(), timeout_s,
                   if_nametoindex(name.c_str()) == 0 ? "no such interface" : "it is down",
                   Printable(name).c_str());
      return kNotUp;
    }
    if (!said) {
      std::fprintf(stderr, "mrd-firmware: waiting up to %g s for CAN interface %s\n", timeout_s,
                   Printable(name).c_str());
      said = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  std::printf("CAN interface %s is up (after %.1f s)\n", Printable(name).c_str(), waited());
  return kOk;
}

}  // namespace mrd::firmware
