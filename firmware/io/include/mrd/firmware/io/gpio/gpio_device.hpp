#pragma once
// The GPIO field device: driver-enable and heartbeat outputs, a fault input and a quadrature
// encoder (two edge-event inputs) as the displacement source, on a GPIO character device
// (libgpiod 1.6) or on the simulated chip shared with a test peer or mrd-hil (gpio_chip.hpp).
//
// Why non-blocking reads in the tick, not an I/O thread: every operation is one ioctl or one
// read on a non-blocking line fd (libgpiod), or a few loads from shared memory (simulated
// chip), a few microseconds at most, and the kernel's per-line event queue already is the
// mailbox between the pins and the loop (it keeps the kernel's timestamps, so reading an edge a
// period late loses nothing but latency). A thread would add a hand-over, its latency and its
// scheduling jitter without removing any wait. (Modbus is different: libmodbus blocks.)
//
// Per period:
//   Read   fault line: its level (active high, or low with fault_active_low) becomes the
//          frame's fault input (the watchdog's fault_line cause). Encoder: up to
//          kMaxEdgesPerRead pending edges per line are read (never waiting), merged by
//          timestamp and decoded (mrd/protocol/quadrature.hpp); displacement [cm] =
//          count / counts_per_cm, relative to the position at Activate (an incremental
//          encoder: a board homes the damper before starting). Edges newer than
//          now - kEdgeHorizonNs are held to the next period, so an edge of one line stamped
//          before an edge of the other, but read after it, is still applied in order; when
//          a line's queue holds more than the bound, the other line's edges wait past the
//          newest edge read from it.
//          The sample's stamp: when both lines' queues were drained, the horizon (the count
//          is the position up to then: no edge means no motion, so a damper at rest is not
//          stale); when edges are still queued (more than the per-period bound), the
//          latest applied edge's kernel timestamp, so a backlog ages the sample.
//          An illegal transition (both lines changed in one event, or an edge contradicting
//          the line's level) is rejected: the count holds, rx_rejected and
//          errors[rejected_frame] count it. Edges the queue dropped (overflow) are counted
//          (errors[overflow], rx_rejected) and make the period kFault: the position may be
//          off. A failed system call is kFault (system): the gpio_bus watchdog cause.
//   Write  enable line = cmd.enable && !cmd.safe (low in the safe state); heartbeat line
//          toggles once per write (the loop writes once per period). A failed write is
//          kFault (system); tx_ok / tx_failed count line writes.
// Deactivate drives enable low and releases the lines. A GPIO chip does not come and go like
// a bus peer: there is no reconnection (reconnects stays 0).

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "mrd/firmware/io/bus_device.hpp"
#include "mrd/firmware/io/gpio/gpio_chip.hpp"
#include "mrd/firmware/seqlock.hpp"
#include "mrd/protocol/quadrature.hpp"

namespace mrd::firmware {

class GpioDevice final : public BusDevice {
 public:
  static constexpr std::size_t kMaxEdgesPerRead = 64;      // per line and period
  static constexpr std::int64_t kEdgeHorizonNs = 200'000;  // edges younger wait a period

  // The chip from config (libgpiod for 'chip', the simulated chip for 'sim_chip').
  explicit GpioDevice(const GpioConfig& config);
  // On a given chip (tests).
  GpioDevice(const GpioConfig& config, std::unique_ptr<GpioChip> chip);
  ~GpioDevice() override { Deactivate(); }

  const char* name() const override { return "gpio"; }
  FaultCause fault_cause() const override { return FaultCause::kGpioBus; }
  // Opens the chip, requests the routed lines (enable low, heartbeat low).
  bool Configure(std::string* error) override;
  // Zeroes the encoder at the current levels (pending edges discarded); enable stays low.
  bool Activate(std::string* error) override;
  // Enable low, lines released. Idempotent.
  void Deactivate() override;
  IoStatus Read(const IoTime& t, SensorFrame* frame, IoError* why) override;
  IoStatus Write(const IoTime& t, const DriverCommand& cmd, IoError* why) override;
  DeviceCounters counters() const override { return published_.Read(); }

  // Loop-thread views (tests and diagnostics).
  bool enable_level() const { return enable_; }
  bool fault_asserted() const { return fault_asserted_; }
  std::int64_t encoder_count() const { return decoder_.count(); }
  std::int64_t last_edge_ns() const { return last_edge_ns_; }

 private:
  struct Pending {
    std::array<protocol::QuadratureEdge, kMaxEdgesPerRead> edges{};
    std::size_t size = 0;
  };
  bool Routed(Input i) const { return (config_.inputs & Bit(i)) != 0; }
  bool Routed(Output o) const { return (config_.outputs & Bit(o)) != 0; }
  void Count(IoError error, std::uint64_t n = 1);
  // Tops up one line's pending edges; false on a failed read. *drained: queue emptied.
  bool Fetch(int line, Pending* p, bool* drained, IoError* fault);
  // Reads and decodes the encoder; the new displacement sample in displacement_.
  void ReadEncoder(std::int64_t now, IoError* fault);
  bool Set(int line, bool level);
  void Publish() { published_.Write(counters_); }

  GpioConfig config_;
  std::unique_ptr<GpioChip> chip_;
  bool open_ = false;
  bool enable_ = false, heartbeat_ = false, fault_asserted_ = false;
  protocol::QuadratureDecoder decoder_;
  Pending pending_a_, pending_b_;
  Stamped displacement_;
  std::int64_t last_edge_ns_ = 0;
  DeviceCounters counters_;
  Seqlock<DeviceCounters> published_;
};

}  // namespace mrd::firmware
