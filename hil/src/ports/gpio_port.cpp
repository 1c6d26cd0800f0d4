#include "mrd/hil/ports/gpio_port.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "mrd/common/clock.hpp"
#include "mrd/protocol/quadrature.hpp"
#include "mrd/sim_gpio/sim_chip.hpp"

namespace mrd::hil {
namespace {

bool ParseInt(const std::string& s, int* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (errno != 0 || *end != '\0' || v < 0 || v > 1'000'000) return false;
  *out = static_cast<int>(v);
  return true;
}

bool ParseDouble(const std::string& s, double* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (*end != '\0' || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

class GpioPort final : public PlantPort {
 public:
  explicit GpioPort(GpioPortConfig config) : c_(std::move(config)) {}
  ~GpioPort() override { Close(); }

  const char* name() const override { return "gpio"; }

  bool Open(std::string* error) override {
    if (!chip_.Open(c_.path, /*create=*/true, error)) return false;
    const std::int64_t now = common::MonotonicNs();
    chip_.SetValue(Line(c_.fault_line), c_.fault_active_low, now);  // not asserted
    // Continue from the levels the chip holds (a restarted harness: no glitch).
    const bool a = chip_.GetValue(Line(c_.encoder_a_line));
    const bool b = chip_.GetValue(Line(c_.encoder_b_line));
    count_ = 0;
    while (protocol::LevelsForCount(count_).a != a || protocol::LevelsForCount(count_).b != b) {
      ++count_;
    }
    heartbeat_head_ = chip_.head(Line(c_.heartbeat_line));
    enable_ = chip_.GetValue(Line(c_.enable_line));
    last_t_ = now;
    return true;
  }

  void Publish(const SensorOutput& out) override {
    if (!chip_.is_open()) return;
    if (!chip_.Check()) {  // the chip file was truncated or overwritten: counted as rejected
      ++failed_;
      return;
    }
    const std::int64_t now = common::MonotonicNs();
    chip_.SetValue(Line(c_.fault_line), out.fault_line != c_.fault_active_low, now);
    const std::int64_t steps = EncoderStepsToward(out.sample.x, c_.counts_per_cm, count_);
    const std::int64_t dir = steps > 0 ? 1 : -1;
    for (std::int64_t i = 0; i != steps; i += dir) {
      const protocol::QuadratureLevels from = protocol::LevelsForCount(count_);
      count_ += dir;
      const protocol::QuadratureLevels to = protocol::LevelsForCount(count_);
      // Distinct, increasing stamps: edges of A and B with one stamp would be one event.
      last_t_ = std::max(common::MonotonicNs(), last_t_ + 1);
      if (to.a != from.a) chip_.SetValue(Line(c_.encoder_a_line), to.a, last_t_);
      if (to.b != from.b) chip_.SetValue(Line(c_.encoder_b_line), to.b, last_t_);
      ++published_;
    }
  }

  void Poll(DriverInput* in) override {
    if (!chip_.is_open() || chip_.damaged()) return;
    const bool enable = chip_.GetValue(Line(c_.enable_line));
    if (enable != enable_) ++received_;
    enable_ = enable;
    in->has_enable = true;
    in->enable = enable;
    const std::uint64_t head = chip_.head(Line(c_.heartbeat_line));
    if (head != heartbeat_head_) {
      received_ += head - heartbeat_head_;
      in->heartbeats += head - heartbeat_head_;  // one toggle per firmware period
      heartbeat_head_ = head;
      in->heartbeat_ns = common::MonotonicNs();
    }
  }

  void Close() override { chip_.Close(); }
  PortCounters counters() const override { return {published_, received_, failed_}; }

 private:
  static std::size_t Line(int offset) { return static_cast<std::size_t>(offset); }

  GpioPortConfig c_;
  sim_gpio::SimChip chip_;
  std::int64_t count_ = 0;
  std::int64_t last_t_ = 0;
  std::uint64_t heartbeat_head_ = 0;
  bool enable_ = false;
  std::uint64_t published_ = 0, received_ = 0, failed_ = 0;
};

}  // namespace

std::int64_t EncoderStepsToward(double x_cm, double counts_per_cm, std::int64_t count) {
  const double target_d = std::round(x_cm * counts_per_cm);
  if (!std::isfinite(target_d) || std::fabs(target_d) > 9e15) return 0;
  const auto target = static_cast<std::int64_t>(target_d);
  return std::clamp<std::int64_t>(target - count, -kMaxStepsPerPublish, kMaxStepsPerPublish);
}

bool ParseGpioEndpoint(const std::string& endpoint, GpioPortConfig* out, std::string* error) {
  GpioPortConfig c;
  std::stringstream ss(endpoint);
  std::string item;
  std::getline(ss, c.path, ',');
  auto fail = [&](const std::string& why) {
    *error = "gpio endpoint '" + endpoint + "': " + why;
    return false;
  };
  if (c.path.empty()) return fail("expected PATH[,KEY=VALUE...]");
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const std::string value = eq == std::string::npos ? "" : item.substr(eq + 1);
    int* line = key == "encoder_a"   ? &c.encoder_a_line
                : key == "encoder_b" ? &c.encoder_b_line
                : key == "fault"     ? &c.fault_line
                : key == "enable"    ? &c.enable_line
                : key == "heartbeat" ? &c.heartbeat_line
                                     : nullptr;
    if (line != nullptr) {
      if (!ParseInt(value, line) || *line >= static_cast<int>(sim_gpio::kNumLines)) {
        return fail("'" + key + "' needs a line offset 0-" +
                    std::to_string(sim_gpio::kNumLines - 1));
      }
    } else if (key == "counts_per_cm") {
      if (!ParseDouble(value, &c.counts_per_cm) || c.counts_per_cm < 1e-3 ||
          c.counts_per_cm > 1e9) {
        return fail("'counts_per_cm' needs a number in [0.001, 1e9]");
      }
    } else if (key == "fault_active_low") {
      if (value != "0" && value != "1") return fail("'fault_active_low' needs 0 or 1");
      c.fault_active_low = value == "1";
    } else {
      return fail("unknown key '" + key +
                  "' (encoder_a, encoder_b, fault, enable, heartbeat, counts_per_cm, "
                  "fault_active_low)");
    }
  }
  const int lines[] = {c.encoder_a_line, c.encoder_b_line, c.fault_line, c.enable_line,
                       c.heartbeat_line};
  for (std::size_t i = 0; i < std::size(lines); ++i) {
    for (std::size_t j = i + 1; j < std::size(lines); ++j) {
      if (lines[i] == lines[j]) return fail("two functions on line " + std::to_string(lines[i]));
    }
  }
  *out = c;
  return true;
}

std::unique_ptr<PlantPort> MakeGpioPort(const GpioPortConfig& config) {
  return std::make_unique<GpioPort>(config);
}

std::unique_ptr<PlantPort> MakeGpioPort(const std::string& endpoint) {
  GpioPortConfig c;
  std::string error;
  if (!ParseGpioEndpoint(endpoint, &c, &error)) return nullptr;
  return MakeGpioPort(c);
}

}  // namespace mrd::hil
