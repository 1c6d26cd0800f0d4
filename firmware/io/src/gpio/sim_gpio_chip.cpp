// GpioChip over the simulated chip (mrd/sim_gpio/sim_chip.hpp): shared memory, and one fstat
// per call on the real-time path (SimChip::Check: a truncated or overwritten chip file fails
// the call, a device fault, instead of a SIGBUS). Edges written by the peer are stamped by the
// peer (CLOCK_MONOTONIC), like a kernel stamps them on a board.
#include <algorithm>
#include <array>

#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/gpio/gpio_chip.hpp"
#include "mrd/sim_gpio/sim_chip.hpp"

namespace mrd::firmware {
namespace {

class SimGpioChip final : public GpioChip {
 public:
  explicit SimGpioChip(std::string path) : path_(std::move(path)) {}

  bool Open(std::string* error) override {
    count_ = 0;
    if (!chip_.Open(path_, /*create=*/false, error)) {
      *error = "gpio: " + *error;
      return false;
    }
    return true;
  }
  bool RequestOutput(int offset, bool initial, std::string* error) override {
    if (!Keep(offset, error)) return false;
    chip_.SetValue(static_cast<std::size_t>(offset), initial, common::MonotonicNs());
    return true;
  }
  bool RequestInput(int offset, std::string* error) override { return Keep(offset, error); }
  bool RequestEdges(int offset, std::string* error) override { return Keep(offset, error); }
  void Close() override {
    count_ = 0;
    chip_.Close();
  }

  bool SetValue(int offset, bool value) override {
    return Find(offset) != nullptr && chip_.Check() &&
           chip_.SetValue(static_cast<std::size_t>(offset), value, common::MonotonicNs());
  }
  int GetValue(int offset) override {
    if (Find(offset) == nullptr || !chip_.Check()) return -1;
    return chip_.GetValue(static_cast<std::size_t>(offset)) ? 1 : 0;
  }
  int ReadEdges(int offset, protocol::QuadratureEdge* out, std::size_t max,
                std::uint64_t* lost) override {
    *lost = 0;
    Held* h = Find(offset);
    if (h == nullptr || !chip_.Check()) return -1;
    std::array<sim_gpio::Event, 64> events{};
    std::size_t n = 0;
    while (n < max) {
      std::uint64_t dropped = 0;
      const std::size_t got =
          chip_.ReadEvents(static_cast<std::size_t>(offset), &h->cursor, events.data(),
                           std::min(events.size(), max - n), &dropped);
      *lost += dropped;
      for (std::size_t i = 0; i < got; ++i) out[n++] = {events[i].t_ns, events[i].rising};
      if (got == 0) break;
    }
    if (chip_.damaged()) return -1;  // truncated while being read: the events may be zeros
    return static_cast<int>(n);
  }

 private:
  struct Held {
    int offset;
    std::uint64_t cursor;  // next event to read
  };
  bool Keep(int offset, std::string* error) {
    if (!chip_.is_open()) {
      *error = "gpio: sim chip " + path_ + " not open";
      return false;
    }
    if (offset < 0 || static_cast<std::size_t>(offset) >= sim_gpio::kNumLines) {
      *error = "gpio: sim chip " + path_ + " has no line " + std::to_string(offset) + " (lines 0-" +
               std::to_string(sim_gpio::kNumLines - 1) + ")";
      return false;
    }
    if (count_ >= kMaxLines) {
      *error = "gpio: more than " + std::to_string(kMaxLines) + " lines requested";
      return false;
    }
    held_[count_++] = {offset, chip_.head(static_cast<std::size_t>(offset))};
    return true;
  }
  Held* Find(int offset) {
    for (std::size_t i = 0; i < count_; ++i) {
      if (held_[i].offset == offset) return &held_[i];
    }
    return nullptr;
  }

  std::string path_;
  sim_gpio::SimChip chip_;
  std::array<Held, kMaxLines> held_{};
  std::size_t count_ = 0;
};

}  // namespace

std::unique_ptr<GpioChip> MakeSimGpioChip(const std::string& path) {
  return std::make_unique<SimGpioChip>(path);
}

}  // namespace mrd::firmware
