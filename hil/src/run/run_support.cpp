// Helpers of the scenario run (run_session.hpp): transport and clock names, the monotonic
// clock, files and directories, the CAN log, --sdo-refuse, the firmware's argv.
#include <linux/can.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>

#include "run_internal.hpp"
#include "run_session.hpp"

namespace mrd::hil {

const char* TransportName(Transport t) {
  switch (t) {
    case Transport::kCan:
      return "can";
    case Transport::kModbusTcp:
      return "modbus-tcp";
    case Transport::kModbusRtu:
      return "modbus-rtu";
  }
  return "can";
}

const char* ClockName(Clock c) { return c == Clock::kRealtime ? "realtime" : "lockstep"; }

bool ParseTransport(const std::string& name, Transport* t) {
  for (const Transport x : {Transport::kCan, Transport::kModbusTcp, Transport::kModbusRtu}) {
    if (name == TransportName(x)) {
      *t = x;
      return true;
    }
  }
  return false;
}

bool ParseClock(const std::string& name, Clock* c) {
  for (const Clock x : {Clock::kLockstep, Clock::kRealtime}) {
    if (name == ClockName(x)) {
      *c = x;
      return true;
    }
  }
  return false;
}

std::string FormatSeconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g s", s);
  return buf;
}

std::string Tag(int n) {
  char buf[16] = "";
  if (n > 0) std::snprintf(buf, sizeof buf, ".%d", n);
  return buf;
}

std::string InterruptText(int sig) {
  std::string text = "interrupted by ";
  text += strsignal(sig);
  return text;
}

bool MakeDirs(const std::string& dir) {
  std::string partial;
  std::stringstream ss(dir);
  std::string part;
  if (!dir.empty() && dir[0] == '/') partial.push_back('/');
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    partial += part;
    partial += '/';
    if (mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST) return false;
  }
  return true;
}

bool ReadFile(const std::string& path, std::string* out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::stringstream s;
  s << in.rdbuf();
  *out = s.str();
  return true;
}

bool CanLog::Open(const std::string& path, std::string* error) {
  file = std::fopen(path.c_str(), "w");
  if (file == nullptr) *error = path + ": cannot write the CAN log (" + std::strerror(errno) + ")";
  return file != nullptr;
}

void CanLog::Write(void* context, const void* frame, bool /*in_process*/) {
  auto* log = static_cast<CanLog*>(context);
  can_frame f;
  std::memcpy(&f, frame, sizeof f);
  const std::int64_t t = log->t_ns >= 0 ? log->t_ns : common::MonotonicNs();
  const bool extended = (f.can_id & CAN_EFF_FLAG) != 0;
  std::fprintf(log->file, "(%lld.%06lld) mrdbus ", static_cast<long long>(t / 1'000'000'000),
               static_cast<long long>(t % 1'000'000'000 / 1000));
  std::fprintf(log->file, extended ? "%08X#" : "%03X#",
               f.can_id & (extended ? CAN_EFF_MASK : CAN_SFF_MASK));
  for (int i = 0; i < f.len && i < 8; ++i) std::fprintf(log->file, "%02X", f.data[i]);
  std::fputc('\n', log->file);
}

CanLog::~CanLog() {
  if (file != nullptr) std::fclose(file);
}

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

std::vector<std::string> FirmwareArgv(const RunOptions& o, const std::string& config,
                                      const std::string& table, double duration_s) {
  // The harness is the plant: the demo table may drive it on any interface (vcan on a board).
  std::vector<std::string> argv = {o.firmware, "--config", config, "--json", "--allow-demo-table"};
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

SensorFault SensorFaultOf(FaultKind k) {
  switch (k) {
    case FaultKind::kDrop:
      return SensorFault::kDrop;
    case FaultKind::kCorrupt:
      return SensorFault::kCorrupt;
    case FaultKind::kStall:
      return SensorFault::kStall;
    case FaultKind::kOutOfRange:
      return SensorFault::kOutOfRange;
    case FaultKind::kNan:
      return SensorFault::kNan;
    default:
      return SensorFault::kNone;
  }
}

}  // namespace mrd::hil
