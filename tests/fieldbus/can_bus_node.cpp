// mrd_can_node — a test node on the local frame bus (docs/can_bus.md), for the process-level
// CAN tests:
//   capture  writes every frame it hears as a `candump -L` line, stamped with the relay's
//            bus stamp (CLOCK_MONOTONIC seconds; CanIface): "(SEC.USEC) localbus ID#DATA";
//            --valid-only leaves out (counts) frames of checksummed IDs whose checksum is wrong
//            (a babbling node's: the log stays small)
//   babble   a babbling node: RATE frames per millisecond (absolute 1 ms deadlines) with the
//            given IDs, DLC 8 and a wrong checksum, spread over NODES connections; reports
//            its own pauses (descheduled for more than 20 ms)
// Both run until SIGTERM/SIGINT or --duration, then print a JSON line of counts.
// Usage:
//   mrd_can_node capture --socket PATH --out FILE [--valid-only] [--duration S]
//   mrd_can_node babble --socket PATH --rate N [--ids 100,101] [--nodes K] [--duration S]
#include <poll.h>
#include <sys/socket.h>

#include <atomic>
#include <cinttypes>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "mrd/canbus/can_iface.hpp"
#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/protocol/can_codec.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop.store(true); }

struct Options {
  std::string mode, socket, out, ids = "100,101";
  double duration_s = 0.0, rate = 200.0;
  int nodes = 2;
  bool valid_only = false;
};

bool Parse(int argc, char** argv, Options* o) {
  if (argc < 2) return false;
  o->mode = argv[1];
  for (int i = 2; i < argc; i += 2) {
    if (std::string(argv[i]) == "--valid-only") {
      o->valid_only = true;
      --i;
      continue;
    }
    if (i + 1 >= argc) return false;
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--socket")
      o->socket = v;
    else if (k == "--out")
      o->out = v;
    else if (k == "--ids")
      o->ids = v;
    else if (k == "--duration")
      o->duration_s = std::atof(v.c_str());
    else if (k == "--rate")
      o->rate = std::atof(v.c_str());
    else if (k == "--nodes")
      o->nodes = std::atoi(v.c_str());
    else
      return false;
  }
  if (o->socket.empty()) return false;
  return o->mode == "babble" ? o->rate > 0.0 && o->nodes > 0
                             : o->mode == "capture" && !o->out.empty();
}

bool Expired(std::int64_t end_ns) {
  return g_stop.load() || (end_ns != 0 && mrd::common::MonotonicNs() >= end_ns);
}

int Capture(const Options& o, std::int64_t end_ns) {
  std::string error;
  const int fd = mrd::canbus::OpenLocalBusNode(o.socket.c_str(), &error);
  if (fd < 0) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  // CanIface: the relay's bus stamp (or, from a relay sending bare frames, the kernel's).
  mrd::canbus::CanIface iface;
  iface.Attach(fd);
  std::FILE* out = std::fopen(o.out.c_str(), "w");
  if (out == nullptr) {
    std::fprintf(stderr, "error: %s: cannot write\n", o.out.c_str());
    return 1;
  }
  static char buffer[1 << 20];
  std::setvbuf(out, buffer, _IOFBF, sizeof buffer);
  std::uint64_t frames = 0, invalid = 0;
  std::int64_t invalid_first = 0, invalid_last = 0;  // bus stamps of the left-out frames [ns]
  while (!Expired(end_ns) && iface.is_open()) {
    pollfd p{iface.fd(), POLLIN, 0};
    if (poll(&p, 1, 50) <= 0) continue;
    for (int k = 0; k < 256; ++k) {
      can_frame f{};
      std::int64_t stamp = 0;
      const mrd::canbus::CanResult r = iface.Receive(&f, &stamp);
      if (r == mrd::canbus::CanResult::kEmpty || r == mrd::canbus::CanResult::kDisconnected) break;
      if (r != mrd::canbus::CanResult::kOk) continue;  // counted in the stats
      namespace pc = mrd::protocol::can;
      const pc::Message m = pc::Classify(f);
      if (o.valid_only && m != pc::Message::kUnknown && m != pc::Message::kFirmwareStatus &&
          f.len >= 1 && f.len <= 8 && pc::Checksum(f) != f.data[f.len - 1]) {
        if (invalid++ == 0) invalid_first = stamp;
        invalid_last = stamp;
        continue;
      }
      const std::int64_t us = stamp / 1000;
      std::fprintf(out, "(%" PRId64 ".%06" PRId64 ") localbus %03X#", us / 1'000'000,
                   us % 1'000'000, f.can_id & CAN_SFF_MASK);
      for (int i = 0; i < f.len && i < 8; ++i) std::fprintf(out, "%02X", f.data[i]);
      std::fputc('\n', out);
      ++frames;
    }
  }
  const bool ok = std::fclose(out) == 0;
  std::printf("{\"frames\": %" PRIu64 ", \"bad_packets\": %" PRIu64
              ", \"left_out_bad_checksum\": %" PRIu64
              ", \"left_out_first_s\": %.6f, \"left_out_last_s\": %.6f}\n",
              frames, iface.stats().rx_bad, invalid, static_cast<double>(invalid_first) * 1e-9,
              static_cast<double>(invalid_last) * 1e-9);
  return ok ? 0 : 1;
}

int Babble(const Options& o, std::int64_t end_ns) {
  std::vector<canid_t> ids;
  for (const char* p = o.ids.c_str(); *p != '\0';) {
    char* end = nullptr;
    ids.push_back(static_cast<canid_t>(std::strtoul(p, &end, 16)));
    p = *end == ',' ? end + 1 : end;
    if (end == p && *p != '\0') return 2;
  }
  std::vector<int> fds;
  for (int i = 0; i < o.nodes; ++i) {
    std::string error;
    const int fd = mrd::canbus::OpenLocalBusNode(o.socket.c_str(), &error);
    if (fd < 0) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 1;
    }
    fds.push_back(fd);
  }
  std::uint64_t sent = 0, blocked = 0, n = 0;
  const std::int64_t start = mrd::common::MonotonicNs();
  std::int64_t deadline = start;
  double owed = 0.0;
  // Its own pauses (descheduled longer than kPauseNs): the bus was not flooded meanwhile.
  constexpr std::int64_t kPauseNs = 20'000'000;
  std::string pauses;
  std::int64_t last = start;
  while (!Expired(end_ns)) {
    const std::int64_t now = mrd::common::MonotonicNs();
    if (now - last > kPauseNs) {
      char b[64];
      std::snprintf(b, sizeof b, "%s[%.6f, %.6f]", pauses.empty() ? "" : ", ",
                    static_cast<double>(last) * 1e-9, static_cast<double>(now) * 1e-9);
      pauses += b;
    }
    last = now;
    owed += o.rate;
    for (; owed >= 1.0; owed -= 1.0, ++n) {
      can_frame f{};
      f.can_id = ids[static_cast<std::size_t>(n % ids.size())];
      f.len = 8;
      for (int i = 0; i < 7; ++i) f.data[i] = static_cast<std::uint8_t>((n * 37 + i * 11) & 0xFF);
      f.data[7] = static_cast<std::uint8_t>(mrd::protocol::can::Checksum(f) ^ 0x5A);  // never valid
      const int fd = fds[static_cast<std::size_t>(n % fds.size())];
      if (send(fd, &f, sizeof f, MSG_DONTWAIT | MSG_NOSIGNAL) == static_cast<ssize_t>(sizeof f)) {
        ++sent;
      } else {
        ++blocked;
      }
    }
    deadline += 1'000'000;
    (void)mrd::common::SleepUntilNs(deadline);
  }
  const double seconds = static_cast<double>(mrd::common::MonotonicNs() - start) * 1e-9;
  std::printf("{\"sent\": %" PRIu64 ", \"would_block\": %" PRIu64
              ", \"seconds\": %.3f, \"pauses\": [%s]}\n",
              sent, blocked, seconds, pauses.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!Parse(argc, argv, &o)) {
    std::fprintf(
        stderr,
        "usage: mrd_can_node capture --socket PATH --out FILE [--valid-only] [--duration S]\n"
        "       mrd_can_node babble --socket PATH --rate N [--ids 100,101] [--nodes K] "
        "[--duration S]\n");
    return 2;
  }
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGPIPE, SIG_IGN);
  const std::int64_t end_ns = o.duration_s > 0.0 ? mrd::common::MonotonicNs() +
                                                       static_cast<std::int64_t>(o.duration_s * 1e9)
                                                 : 0;
  return o.mode == "capture" ? Capture(o, end_ns) : Babble(o, end_ns);
}
