#pragma once
// The far side of the GPIO device in unit tests: creates a simulated chip file and plays the
// encoder and fault line on it (and reads the device's outputs), like mrd-hil's GPIO port.

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <string>

#include "mrd/common/clock.hpp"
#include "mrd/protocol/quadrature.hpp"
#include "mrd/sim_gpio/sim_chip.hpp"

namespace mrd::test {

struct GpioLines {
  int a = 4, b = 5, fault = 6, enable = 17, heartbeat = 18;
};

class GpioPeer {
 public:
  explicit GpioPeer(const std::string& tag)
      : path_("/tmp/mrd-gpio-" + tag + "-" + std::to_string(getpid()) + ".chip") {
    unlink(path_.c_str());
    std::string error;
    ok_ = chip_.Open(path_, /*create=*/true, &error);
    error_ = error;
  }
  ~GpioPeer() {
    chip_.Close();
    unlink(path_.c_str());
  }

  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }
  const std::string& path() const { return path_; }
  sim_gpio::SimChip& chip() { return chip_; }

  // Walks the encoder to `target`, one edge per step, stamped `age_ns` in the past (older than
  // the device's horizon by default, so the next Read applies them).
  void MoveTo(std::int64_t target, std::int64_t age_ns = 2'000'000) {
    while (count_ != target) {
      const protocol::QuadratureLevels from = protocol::LevelsForCount(count_);
      count_ += target > count_ ? 1 : -1;
      const protocol::QuadratureLevels to = protocol::LevelsForCount(count_);
      const std::int64_t t = Stamp(age_ns);
      if (to.a != from.a) chip_.SetValue(lines.a, to.a, t);
      if (to.b != from.b) chip_.SetValue(lines.b, to.b, t);
    }
  }
  // Both encoder lines change with one stamp (an illegal transition: two counts at once).
  void Glitch(std::int64_t age_ns = 2'000'000) {
    const std::int64_t t = Stamp(age_ns);
    chip_.SetValue(lines.a, !chip_.GetValue(lines.a), t);
    chip_.SetValue(lines.b, !chip_.GetValue(lines.b), t);
    count_ += 2;  // where the peer now is (phase + 2); the decoder cannot know the direction
  }
  void SetFault(bool level) { chip_.SetValue(lines.fault, level, common::MonotonicNs()); }
  bool enable() const { return chip_.GetValue(lines.enable); }
  bool heartbeat() const { return chip_.GetValue(lines.heartbeat); }
  std::uint64_t heartbeat_edges() const { return chip_.head(lines.heartbeat); }
  std::int64_t count() const { return count_; }

  GpioLines lines;

 private:
  std::int64_t Stamp(std::int64_t age_ns) {
    last_t_ = std::max(common::MonotonicNs() - age_ns, last_t_ + 1);
    return last_t_;
  }

  std::string path_;
  sim_gpio::SimChip chip_;
  bool ok_ = false;
  std::string error_;
  std::int64_t count_ = 0;
  std::int64_t last_t_ = 0;
};

}  // namespace mrd::test
