#pragma once
// The few GPIO operations the GPIO device needs, behind one interface with two
// implementations: a GPIO character device through libgpiod 1.6 (a board; needs a real chip
// or the virtual board) and the simulated chip shared with a test peer or the HIL harness
// (mrd/sim_gpio/sim_chip.hpp). Lines are named by their offset on the chip.
//
// Open and Request* are start-up (may allocate, block); SetValue, GetValue and ReadEdges are
// real-time safe: no allocation, at most one non-blocking system call (libgpiod: an ioctl or a
// read on a non-blocking line fd), never a wait.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "mrd/protocol/quadrature.hpp"

namespace mrd::firmware {

class GpioChip {
 public:
  static constexpr std::size_t kMaxLines = 8;  // lines one device requests at most

  virtual ~GpioChip() = default;
  // false with *error ("gpio: ...").
  virtual bool Open(std::string* error) = 0;
  // Output line driven to `initial`.
  virtual bool RequestOutput(int offset, bool initial, std::string* error) = 0;
  // Input line whose level is read.
  virtual bool RequestInput(int offset, std::string* error) = 0;
  // Input line with both-edge events (only edges after the request are reported).
  virtual bool RequestEdges(int offset, std::string* error) = 0;
  // Releases the lines (outputs keep their last level on a real chip) and the chip.
  virtual void Close() = 0;

  // Drives a requested output. false: not requested or the system call failed.
  virtual bool SetValue(int offset, bool value) = 0;
  // Level of a requested line: 0 or 1; -1 on failure.
  virtual int GetValue(int offset) = 0;
  // Pending edges of an edge line, oldest first, at most max, stamped by the kernel
  // (CLOCK_MONOTONIC [ns]); *lost: edges known to be dropped (queue overflow) since the last
  // call. -1 on failure.
  virtual int ReadEdges(int offset, protocol::QuadratureEdge* out, std::size_t max,
                        std::uint64_t* lost) = 0;
};

// A GPIO character device by name, number or path ("gpiochip0", "0", "/dev/gpiochip0").
std::unique_ptr<GpioChip> MakeLibgpiodChip(const std::string& chip);
// The simulated chip at path (it must exist: its peer creates it).
std::unique_ptr<GpioChip> MakeSimGpioChip(const std::string& path);

}  // namespace mrd::firmware
