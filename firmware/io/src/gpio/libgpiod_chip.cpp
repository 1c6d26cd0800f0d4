// GpioChip over libgpiod 1.6 (GPIO character device, uAPI v1). Event fds are switched to
// O_NONBLOCK so a read of pending edges never waits; the kernel stamps edges with
// CLOCK_MONOTONIC (Linux >= 5.7). uAPI v1 carries no event sequence numbers: a kernel queue
// overflow shows up as an edge that contradicts the line's level (a glitch to the decoder).
#include <fcntl.h>
#include <gpiod.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

#include "mrd/firmware/io/gpio/gpio_chip.hpp"

namespace mrd::firmware {
namespace {

constexpr const char* kConsumer = "mrd-firmware";

class LibgpiodChip final : public GpioChip {
 public:
  explicit LibgpiodChip(std::string name) : name_(std::move(name)) {}
  ~LibgpiodChip() override { Close(); }

  bool Open(std::string* error) override {
    Close();
    chip_ = gpiod_chip_open_lookup(name_.c_str());
    if (chip_ == nullptr) {
      *error = "gpio: cannot open chip '" + name_ + "': " + std::strerror(errno);
      return false;
    }
    return true;
  }

  bool RequestOutput(int offset, bool initial, std::string* error) override {
    gpiod_line* line = Get(offset, error);
    if (line == nullptr) return false;
    if (gpiod_line_request_output(line, kConsumer, initial ? 1 : 0) != 0) {
      return Fail(offset, "request as output", error);
    }
    return Keep(offset, line, error);
  }

  bool RequestInput(int offset, std::string* error) override {
    gpiod_line* line = Get(offset, error);
    if (line == nullptr) return false;
    if (gpiod_line_request_input(line, kConsumer) != 0) {
      return Fail(offset, "request as input", error);
    }
    return Keep(offset, line, error);
  }

  bool RequestEdges(int offset, std::string* error) override {
    gpiod_line* line = Get(offset, error);
    if (line == nullptr) return false;
    if (gpiod_line_request_both_edges_events(line, kConsumer) != 0) {
      return Fail(offset, "request edge events on", error);
    }
    const int fd = gpiod_line_event_get_fd(line);
    const int flags = fd >= 0 ? fcntl(fd, F_GETFL) : -1;
    if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0) {
      gpiod_line_release(line);
      return Fail(offset, "make non-blocking the events of", error);
    }
    return Keep(offset, line, error);
  }

  void Close() override {
    for (std::size_t i = 0; i < count_; ++i) gpiod_line_release(lines_[i].line);
    count_ = 0;
    if (chip_ != nullptr) gpiod_chip_close(chip_);
    chip_ = nullptr;
  }

  bool SetValue(int offset, bool value) override {
    gpiod_line* line = Find(offset);
    return line != nullptr && gpiod_line_set_value(line, value ? 1 : 0) == 0;
  }

  int GetValue(int offset) override {
    gpiod_line* line = Find(offset);
    return line != nullptr ? gpiod_line_get_value(line) : -1;
  }

  int ReadEdges(int offset, protocol::QuadratureEdge* out, std::size_t max,
                std::uint64_t* lost) override {
    *lost = 0;
    gpiod_line* line = Find(offset);
    if (line == nullptr) return -1;
    const int fd = gpiod_line_event_get_fd(line);
    std::array<gpiod_line_event, 16> events{};  // the kernel's queue depth (uAPI v1)
    std::size_t n = 0;
    while (n < max) {
      const auto want = static_cast<unsigned>(std::min(events.size(), max - n));
      const int got = gpiod_line_event_read_fd_multiple(fd, events.data(), want);
      if (got < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK) break;
        return -1;
      }
      for (int i = 0; i < got; ++i) {
        const timespec& ts = events[static_cast<std::size_t>(i)].ts;
        out[n++] = {static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec,
                    events[static_cast<std::size_t>(i)].event_type == GPIOD_LINE_EVENT_RISING_EDGE};
      }
      if (static_cast<unsigned>(got) < want) break;
    }
    return static_cast<int>(n);
  }

 private:
  struct Held {
    int offset;
    gpiod_line* line;
  };

  gpiod_line* Get(int offset, std::string* error) {
    if (chip_ == nullptr) {
      *error = "gpio: chip '" + name_ + "' not open";
      return nullptr;
    }
    if (count_ >= kMaxLines) {
      *error = "gpio: more than " + std::to_string(kMaxLines) + " lines requested";
      return nullptr;
    }
    gpiod_line* line =
        offset >= 0 ? gpiod_chip_get_line(chip_, static_cast<unsigned>(offset)) : nullptr;
    if (line == nullptr) {
      *error = "gpio: chip '" + name_ + "' has no line " + std::to_string(offset) + " (" +
               std::strerror(errno) + ")";
    }
    return line;
  }
  bool Fail(int offset, const char* what, std::string* error) {
    *error = std::string("gpio: cannot ") + what + " line " + std::to_string(offset) +
             " of chip '" + name_ + "': " + std::strerror(errno);
    return false;
  }
  bool Keep(int offset, gpiod_line* line, std::string* error) {
    (void)error;
    lines_[count_++] = {offset, line};
    return true;
  }
  gpiod_line* Find(int offset) const {
    for (std::size_t i = 0; i < count_; ++i) {
      if (lines_[i].offset == offset) return lines_[i].line;
    }
    return nullptr;
  }

  std::string name_;
  gpiod_chip* chip_ = nullptr;
  std::array<Held, kMaxLines> lines_{};
  std::size_t count_ = 0;
};

}  // namespace

std::unique_ptr<GpioChip> MakeLibgpiodChip(const std::string& chip) {
  return std::make_unique<LibgpiodChip>(chip);
}

}  // namespace mrd::firmware
