#include "mrd/firmware/controller.hpp"

#include <cmath>
#include <limits>

namespace mrd::firmware {
namespace {

// Bits of the causes a required signal raises: stale (never sampled or older than max_age),
// non-finite.
std::uint32_t Check(const Stamped& s, std::int64_t now_ns, std::int64_t max_age_ns) {
  std::uint32_t causes = 0;
  if (s.stamp_ns == std::numeric_limits<std::int64_t>::min() || now_ns - s.stamp_ns > max_age_ns) {
    causes |= Watchdog::Bit(FaultCause::kStaleSensor);
  }
  if (!std::isfinite(s.value)) causes |= Watchdog::Bit(FaultCause::kNonFinite);
  return causes;
}

// True when a finite value exceeds a limit (limit 0: none).
bool Implausible(double value, double limit) { return limit > 0.0 && std::fabs(value) > limit; }

}  // namespace

Error Controller::Configure(const CoefficientTable& table, const ControllerConfig& config) {
  Error e = runtime_.Configure(table);
  if (e != Error::kOk) return e;
  e = inverter_.Configure(table);
  if (e != Error::kOk) return e;
  e = inverter_.SetRange(table.e_min, config.e_max);
  if (e != Error::kOk) return e;
  if (!(config.velocity_limit >= 0.0) || !(config.displacement_limit >= 0.0)) {
    return Error::kOutOfRange;  // negative or NaN
  }
  if (!std::isfinite(config.safe_voltage) || config.safe_voltage < table.e_min ||
      config.safe_voltage > table.e_max) {
    return Error::kOutOfRange;
  }
  if (!config.law.IsValid(table.e_min, config.e_max)) return Error::kOutOfRange;
  if (config.watchdog.max_age_ns <= 0 || config.watchdog.recover_periods == 0) {
    return Error::kOutOfRange;
  }
  if (!differentiator_.Configure(config.cutoff_hz)) return Error::kOutOfRange;
  config_ = config;
  e_min_ = table.e_min;
  law_.Configure(config.law, table.e_min, config.e_max);
  watchdog_.Configure(config.watchdog);
  Reset();
  return Error::kOk;
}

void Controller::Reset() {
  runtime_.Reset();
  differentiator_.Reset();
  watchdog_.Reset();
  v_ = 0.0;
  x_ = 0.0;
  E_prev_ = config_.safe_voltage;
  model_resets_ = 0;
}

ControllerOutput Controller::Update(const SensorFrame& frame, IoStatus read_status,
                                    bool driver_fault, std::int64_t now_ns, double dt_s) {
  const std::int64_t max_age = config_.watchdog.max_age_ns;
  std::uint32_t causes = 0;
  constexpr std::uint32_t kBusBits = Watchdog::Bit(FaultCause::kCanBus) |
                                      Watchdog::Bit(FaultCause::kModbusBus) |
                                      Watchdog::Bit(FaultCause::kGpioBus);
  if ((frame.bus_faults & kBusBits) != 0) {
    causes |= frame.bus_faults & kBusBits;
  } else if (read_status == IoStatus::kFault) {
    causes |= Watchdog::Bit(FaultCause::kBusFault);
  }
  if (driver_fault) causes |= Watchdog::Bit(FaultCause::kDriverFault);
  if (frame.fault_line) causes |= Watchdog::Bit(FaultCause::kFaultLine);

  // Velocity (and displacement when the model or the differentiator reads it).
  const bool use_x =
      config_.velocity_source == VelocitySource::kDisplacement || runtime_.reads_displacement();
  constexpr std::uint32_t kImplausibleBit = Watchdog::Bit(FaultCause::kImplausible);
  if (config_.velocity_source == VelocitySource::kMeasured) {
    const std::uint32_t c = Check(frame.velocity, now_ns, max_age);
    causes |= c;
    if (Implausible(frame.velocity.value, config_.velocity_limit)) {
      causes |= kImplausibleBit;
    } else if (std::isfinite(frame.velocity.value)) {
      v_ = frame.velocity.value;
    }
  }
  if (use_x) {
    const std::uint32_t c = Check(frame.displacement, now_ns, max_age);
    causes |= c;
    if (Implausible(frame.displacement.value, config_.displacement_limit)) {
      causes |= kImplausibleBit;
    } else if (std::isfinite(frame.displacement.value)) {
      x_ = frame.displacement.value;
      if (config_.velocity_source == VelocitySource::kDisplacement) {
        const double v = differentiator_.Update(x_, dt_s);
        if (Implausible(v, config_.velocity_limit)) {
          causes |= kImplausibleBit;
        } else {
          v_ = v;
        }
      }
    }
  }
  if (law_.needs_demand()) causes |= Check(frame.demand, now_ns, max_age);
  if (law_.needs_body_velocity()) causes |= Check(frame.body_velocity, now_ns, max_age);

  ControllerOutput out;
  out.causes = causes;
  out.safe = watchdog_.Update(causes);
  runtime_.Begin(v_, x_);
  if (out.safe) {
    out.volts = config_.safe_voltage;
  } else {
    const ControlOutput law = law_.Update({v_, frame.demand.value, frame.body_velocity.value});
    if (law.is_force) {
      const Inverter::Solution s = inverter_.Solve(runtime_.history(), law.value, E_prev_);
      out.volts = s.E;
      out.force_demand = law.value;
      out.force_law = true;
      out.reachable = s.reachable;
    } else {
      out.volts = std::fmin(std::fmax(law.value, e_min_), config_.e_max);
    }
  }
  out.model_force = runtime_.Finish(out.volts);
  if (!std::isfinite(out.model_force)) {  // a diverging model must not poison later periods
    runtime_.Reset();
    ++model_resets_;
  }
  E_prev_ = out.volts;
  return out;
}

}  // namespace mrd::firmware
