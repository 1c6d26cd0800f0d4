#include "mrd/firmware/io/gpio/gpio_device.hpp"

#include <algorithm>
#include <ctime>
#include <memory>

#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/devices.hpp"

namespace mrd::firmware {
namespace {

std::unique_ptr<GpioChip> ChipFor(const GpioConfig& config) {
  return config.sim_chip.empty() ? MakeLibgpiodChip(config.chip) : MakeSimGpioChip(config.sim_chip);
}

// Discards the pending edges of a line. false on a failed read.
bool Drain(GpioChip& chip, int line, std::uint64_t* seen) {
  std::array<protocol::QuadratureEdge, 64> buf{};
  for (int k = 0; k < 1000; ++k) {
    std::uint64_t lost = 0;
    const int n = chip.ReadEdges(line, buf.data(), buf.size(), &lost);
    if (n < 0) return false;
    *seen += static_cast<std::uint64_t>(n) + lost;
    if (static_cast<std::size_t>(n) < buf.size()) return true;
  }
  return true;
}

}  // namespace

GpioDevice::GpioDevice(const GpioConfig& config) : GpioDevice(config, ChipFor(config)) {}

GpioDevice::GpioDevice(const GpioConfig& config, std::unique_ptr<GpioChip> chip)
    : config_(config), chip_(std::move(chip)) {
  Publish();
}

bool GpioDevice::Configure(std::string* error) {
  if (open_) return true;
  if (chip_ == nullptr) {
    *error = "gpio: no chip";
    return false;
  }
  if (!chip_->Open(error)) return false;
  bool ok = true;
  if (Routed(Output::kEnable)) ok = ok && chip_->RequestOutput(config_.enable_line, false, error);
  if (Routed(Output::kHeartbeat)) {
    ok = ok && chip_->RequestOutput(config_.heartbeat_line, false, error);
  }
  if (Routed(Input::kFaultLine)) ok = ok && chip_->RequestInput(config_.fault_line, error);
  if (Routed(Input::kDisplacement)) {
    ok = ok && chip_->RequestEdges(config_.encoder_a_line, error) &&
         chip_->RequestEdges(config_.encoder_b_line, error);
  }
  if (!ok) {
    chip_->Close();
    return false;
  }
  enable_ = heartbeat_ = false;
  open_ = true;
  return true;
}

bool GpioDevice::Activate(std::string* error) {
  if (!open_) {
    *error = "gpio: not configured";
    return false;
  }
  if (Routed(Input::kDisplacement)) {
    // Zero at the current levels. An edge that lands between the drain and the level read
    // is seen by the second drain, and the levels are read again.
    int a = -1, b = -1;
    for (int attempt = 0; attempt < 16; ++attempt) {
      std::uint64_t seen = 0;
      if (!Drain(*chip_, config_.encoder_a_line, &seen) ||
          !Drain(*chip_, config_.encoder_b_line, &seen)) {
        break;
      }
      a = chip_->GetValue(config_.encoder_a_line);
      b = chip_->GetValue(config_.encoder_b_line);
      seen = 0;
      if (!Drain(*chip_, config_.encoder_a_line, &seen) ||
          !Drain(*chip_, config_.encoder_b_line, &seen)) {
        a = -1;
        break;
      }
      if (seen == 0) break;
    }
    if (a < 0 || b < 0) {
      *error = "gpio: cannot read the encoder lines " + std::to_string(config_.encoder_a_line) +
               " and " + std::to_string(config_.encoder_b_line);
      return false;
    }
    decoder_.Reset(a != 0, b != 0, 0);
    pending_a_.size = pending_b_.size = 0;
    displacement_ = Stamped{};  // stamped by the first Read
  }
  return true;
}

void GpioDevice::Deactivate() {
  if (open_) {
    if (Routed(Output::kEnable)) Set(config_.enable_line, false);
    enable_ = false;
    chip_->Close();
    open_ = false;
  }
  Publish();
}

void GpioDevice::Count(IoError error, std::uint64_t n) {
  counters_.errors[static_cast<std::size_t>(error)] += n;
  counters_.last_error = error;
}

bool GpioDevice::Set(int line, bool level) {
  if (chip_->SetValue(line, level)) {
    ++counters_.tx_ok;
    return true;
  }
  ++counters_.tx_failed;
  Count(IoError::kSystem);
  return false;
}

bool GpioDevice::Fetch(int line, Pending* p, bool* drained, IoError* fault) {
  const std::size_t space = p->edges.size() - p->size;
  std::uint64_t lost = 0;
  const int n = space == 0 ? 0 : chip_->ReadEdges(line, p->edges.data() + p->size, space, &lost);
  if (n < 0) {
    Count(IoError::kSystem);
    *fault = IoError::kSystem;
    return false;
  }
  if (lost > 0) {  // the queue overflowed: the count may be off by the lost edges
    counters_.rx_rejected += lost;
    Count(IoError::kOverflow, lost);
    *fault = IoError::kOverflow;
  }
  p->size += static_cast<std::size_t>(n);
  *drained = static_cast<std::size_t>(n) < space;
  return true;
}

void GpioDevice::ReadEncoder(std::int64_t now, IoError* fault) {
  bool drained_a = false, drained_b = false;
  if (!Fetch(config_.encoder_a_line, &pending_a_, &drained_a, fault) ||
      !Fetch(config_.encoder_b_line, &pending_b_, &drained_b, fault)) {
    return;  // the sample keeps its old stamp
  }
  // Apply the edges up to the horizon, and no further than the newest edge read of a line
  // whose queue still holds more (its next edges may be older than the other line's).
  const std::int64_t horizon = now - kEdgeHorizonNs;
  std::int64_t cutoff = horizon;
  if (!drained_a && pending_a_.size > 0) {
    cutoff = std::min(cutoff, pending_a_.edges[pending_a_.size - 1].t_ns);
  }
  if (!drained_b && pending_b_.size > 0) {
    cutoff = std::min(cutoff, pending_b_.edges[pending_b_.size - 1].t_ns);
  }
  std::size_t na = 0, nb = 0;
  while (na < pending_a_.size && pending_a_.edges[na].t_ns <= cutoff) ++na;
  while (nb < pending_b_.size && pending_b_.edges[nb].t_ns <= cutoff) ++nb;
  const protocol::QuadratureBatch batch =
      decoder_.Feed(pending_a_.edges.data(), na, pending_b_.edges.data(), nb);
  counters_.rx_ok += batch.steps;
  if (batch.glitches > 0) {
    counters_.rx_rejected += batch.glitches;
    Count(IoError::kRejectedFrame, batch.glitches);
  }
  if (batch.overflows > 0) {
    counters_.rx_rejected += batch.overflows;
    Count(IoError::kBadValue, batch.overflows);
  }
  if (batch.last_t_ns != 0) last_edge_ns_ = batch.last_t_ns;
  auto shift = [](Pending* p, std::size_t used) {
    for (std::size_t i = used; i < p->size; ++i) p->edges[i - used] = p->edges[i];
    p->size -= used;
  };
  shift(&pending_a_, na);
  shift(&pending_b_, nb);
  const bool caught_up = drained_a && drained_b;
  const std::int64_t stamp = caught_up ? horizon : last_edge_ns_;
  displacement_.value = static_cast<double>(decoder_.count()) / config_.counts_per_cm;
  if (stamp > displacement_.stamp_ns) displacement_.stamp_ns = stamp;
}

IoStatus GpioDevice::Read(const IoTime& t, SensorFrame* frame, IoError* why) {
  if (!open_) {
    *why = IoError::kDisconnected;
    return IoStatus::kFault;
  }
  IoError fault = IoError::kNone;
  bool fresh = false;
  if (Routed(Input::kFaultLine)) {
    const int level = chip_->GetValue(config_.fault_line);
    if (level < 0) {
      Count(IoError::kSystem);
      fault = IoError::kSystem;
    } else {
      fault_asserted_ = (level != 0) != config_.fault_active_low;
      fresh = true;
    }
    // A line that cannot be read counts as asserted: the safe state until it reads again.
    frame->fault_line = frame->fault_line || fault_asserted_ || level < 0;
  }
  if (Routed(Input::kDisplacement)) {
    const std::int64_t before = displacement_.stamp_ns;
    ReadEncoder(t.wall_ns, &fault);  // wall-clock stamps, as the edge thread's
    fresh = fresh || displacement_.stamp_ns != before;
  }
  // The encoder is the one value input a GPIO device serves (configuration checks).
  MergeRouted(config_.inputs, frame, [this](Input) { return displacement_; });
  Publish();
  if (fault != IoError::kNone) {
    *why = fault;
    return IoStatus::kFault;
  }
  return fresh ? IoStatus::kOk : IoStatus::kNoData;
}

IoStatus GpioDevice::Write(const IoTime& t, const DriverCommand& cmd, IoError* why) {
  (void)t;
  if (!open_) {
    ++counters_.tx_failed;
    Publish();
    *why = IoError::kDisconnected;
    return IoStatus::kFault;
  }
  bool ok = true;
  if (Routed(Output::kEnable)) {
    enable_ = cmd.enable && !cmd.safe;
    ok = Set(config_.enable_line, enable_) && ok;
  }
  if (Routed(Output::kHeartbeat)) {
    heartbeat_ = !heartbeat_;
    ok = Set(config_.heartbeat_line, heartbeat_) && ok;
  }
  Publish();
  if (!ok) {
    *why = IoError::kSystem;
    return IoStatus::kFault;
  }
  return IoStatus::kOk;
}

std::unique_ptr<BusDevice> MakeGpioDevice(const GpioConfig& config) {
  return std::make_unique<GpioDevice>(config);
}

}  // namespace mrd::firmware
