#include "mrd/firmware/controller.hpp"

#include <cmath>
#include <limits>

namespace mrd::firmware {
namespace {

// Bits of the causes a required signal raises: stale (never sampled or older than max_age),
// non-finite (value: the sample in Real; a double beyond float's range is non-finite there).
std::uint32_t Check(const Stamped& s, Real value, std::int64_t now_ns, std::int64_t max_age_ns) {
  std::uint32_t causes = 0;
  if (s.stamp_ns == std::numeric_limits<std::int64_t>::min() || now_ns - s.stamp_ns > max_age_ns) {
    causes |= Watchdog::Bit(FaultCause::kStaleSensor);
  }
  if (!std::isfinite(value)) causes |= Watchdog::Bit(FaultCause::kNonFinite);
  return causes;
}

// True once the signal has been sampled (a bus serves it).
bool Measured(const Stamped& s) { return s.stamp_ns != std::numeric_limits<std::int64_t>::min(); }

// Gains the clipped-optimal law can run on: loaded and valid, when the law is selected.
bool ClippedGainsOk(const ControllerConfig& c) {
  return c.law.mode != ControlMode::kClippedOptimal ||
         (c.clipped_gains_loaded && c.clipped_gains.IsValid(nullptr));
}

// The inversion's verdicts on the period's force demand.
void SetInversion(const Inverter::Solution& s, ControllerOutput* out) {
  out->reachable = s.reachable;
  out->passive = s.passive;
  out->monotone = s.monotone;
}

// True when a finite value exceeds a limit (limit 0: none).
bool Implausible(Real value, Real limit) { return limit > Real(0) && std::fabs(value) > limit; }

}  // namespace

ConfigureStatus Controller::Configure(const CoefficientTable& table,
                                      const ControllerConfig& config) {
  const auto refuse = [](ConfigureFault fault, Error e = Error::kOutOfRange) {
    return ConfigureStatus{fault, e};
  };
  Error e = runtime_.Configure(table);
  if (e != Error::kOk) return refuse(ConfigureFault::kTable, e);
  e = inverter_.Configure(table);
  if (e != Error::kOk) return refuse(ConfigureFault::kTable, e);
  e = inverter_.SetRange(table.e_min, config.e_max);
  if (e != Error::kOk) return refuse(ConfigureFault::kEMax, e);
  e = runtime_.SetEnvelope(config.envelope, config.envelope_margin);
  if (e != Error::kOk) return refuse(ConfigureFault::kEnvelope, e);
  if (!(config.velocity_limit >= 0.0) || !(config.displacement_limit >= 0.0)) {
    return refuse(ConfigureFault::kLimits);  // negative or NaN
  }
  if (!std::isfinite(config.safe_voltage) || config.safe_voltage < table.e_min ||
      config.safe_voltage > table.e_max) {
    return refuse(ConfigureFault::kSafeVoltage);
  }
  if (!config.law.IsValid(table.e_min, config.e_max)) return refuse(ConfigureFault::kLaw);
  if (!ClippedGainsOk(config)) return refuse(ConfigureFault::kClippedGains);
  if (config.watchdog.max_age_ns <= 0 || config.watchdog.recover_periods == 0) {
    return refuse(ConfigureFault::kWatchdog);
  }
  if (!differentiator_.Configure(config.cutoff_hz)) return refuse(ConfigureFault::kCutoff);
  config_ = config;
  table_e_min_ = table.e_min;
  table_e_max_ = table.e_max;
  e_min_ = static_cast<Real>(table.e_min);
  e_max_ = static_cast<Real>(config.e_max);
  safe_voltage_ = static_cast<Real>(config.safe_voltage);
  velocity_limit_ = static_cast<Real>(config.velocity_limit);
  displacement_limit_ = static_cast<Real>(config.displacement_limit);
  law_.Configure(config.law, table.e_min, config.e_max);
  if (config.clipped_gains_loaded) clipped_.Configure(config.clipped_gains);
  watchdog_.Configure(config.watchdog);
  Reset();
  return ConfigureStatus{};
}

Error Controller::Retune(const ControllerConfig& config) {
  if (config.velocity_source != config_.velocity_source ||
      config.safe_voltage != config_.safe_voltage ||
      config.watchdog.max_age_ns != config_.watchdog.max_age_ns) {
    return Error::kInvalidArgument;
  }
  // Configure's checks, before anything changes.
  if (!std::isfinite(config.e_max) || !(table_e_min_ < config.e_max) ||
      config.e_max > table_e_max_ || !std::isfinite(config.envelope_margin) ||
      config.envelope_margin < 0.0 || !(config.velocity_limit >= 0.0) ||
      !(config.displacement_limit >= 0.0) || !config.law.IsValid(table_e_min_, config.e_max) ||
      !ClippedGainsOk(config) || config.watchdog.recover_periods == 0 ||
      !std::isfinite(config.cutoff_hz) || !(config.cutoff_hz > 0.0)) {
    return Error::kOutOfRange;
  }
  (void)inverter_.SetRange(table_e_min_, config.e_max);
  (void)runtime_.SetEnvelope(config.envelope, config.envelope_margin);
  (void)differentiator_.SetCutoff(config.cutoff_hz);
  // Switched to the clipped-optimal law: its estimate starts from rest (the gains' arrays are
  // copied into the object: no allocation).
  if (config.law.mode == ControlMode::kClippedOptimal &&
      config_.law.mode != ControlMode::kClippedOptimal) {
    clipped_.Configure(config.clipped_gains);
  }
  config_ = config;
  e_max_ = static_cast<Real>(config.e_max);
  velocity_limit_ = static_cast<Real>(config.velocity_limit);
  displacement_limit_ = static_cast<Real>(config.displacement_limit);
  law_.Configure(config.law, table_e_min_, config.e_max);
  watchdog_.Configure(config.watchdog);
  return Error::kOk;
}

void Controller::Reset() {
  runtime_.Reset();
  differentiator_.Reset();
  clipped_.Reset();
  watchdog_.Reset();
  v_ = Real(0);
  x_ = Real(0);
  model_resets_ = 0;
  model_diverged_ = false;
  runtime_.ClearExcursions();
}

ControllerOutput Controller::Update(const SensorFrame& frame, IoStatus read_status,
                                    bool driver_fault, std::int64_t now_ns, double dt_s) {
  const std::int64_t max_age = config_.watchdog.max_age_ns;
  const Real velocity = static_cast<Real>(frame[Input::kVelocity].value);
  const Real displacement = static_cast<Real>(frame[Input::kDisplacement].value);
  const Real demand = static_cast<Real>(frame[Input::kDemand].value);
  const Real body_velocity = static_cast<Real>(frame[Input::kBodyVelocity].value);
  const Real wheel_velocity = static_cast<Real>(frame[Input::kWheelVelocity].value);
  const Real body_acceleration = static_cast<Real>(frame[Input::kBodyAcceleration].value);
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
    const std::uint32_t c = Check(frame[Input::kVelocity], velocity, now_ns, max_age);
    causes |= c;
    if (Implausible(velocity, velocity_limit_)) {
      causes |= kImplausibleBit;
    } else if (std::isfinite(velocity)) {
      v_ = velocity;
    }
  }
  if (use_x) {
    const std::uint32_t c = Check(frame[Input::kDisplacement], displacement, now_ns, max_age);
    causes |= c;
    if (Implausible(displacement, displacement_limit_)) {
      causes |= kImplausibleBit;
    } else if (std::isfinite(displacement)) {
      x_ = displacement;
      if (config_.velocity_source == VelocitySource::kDisplacement) {
        const Real v = differentiator_.Update(x_, static_cast<Real>(dt_s));
        if (Implausible(v, velocity_limit_)) {
          causes |= kImplausibleBit;
        } else {
          v_ = v;
        }
      }
    }
  } else if (Measured(frame[Input::kDisplacement]) &&
             Implausible(displacement, displacement_limit_)) {
    // Measured though neither the model nor the velocity reads it: the limit still holds.
    causes |= kImplausibleBit;
  }
  if (law_.needs_demand()) causes |= Check(frame[Input::kDemand], demand, now_ns, max_age);
  if (law_.needs_body_velocity()) {
    causes |= Check(frame[Input::kBodyVelocity], body_velocity, now_ns, max_age);
  }
  if (law_.needs_wheel_velocity()) {
    causes |= Check(frame[Input::kWheelVelocity], wheel_velocity, now_ns, max_age);
  }
  if (law_.needs_body_acceleration()) {
    causes |= Check(frame[Input::kBodyAcceleration], body_acceleration, now_ns, max_age);
  }

  // Clipped-optimal: the observer runs on fresh, finite inputs (safe or not); otherwise its
  // estimate restarts from rest. An estimate that turns non-finite is reset and counted.
  Real clipped_volts = e_min_;
  if (config_.law.mode == ControlMode::kClippedOptimal) {
    Real accel[3];
    std::uint32_t c = 0;
    for (int i = 0; i < 3; ++i) {
      accel[i] = static_cast<Real>(frame[FloorAcceleration(i)].value);
      c |= Check(frame[FloorAcceleration(i)], accel[i], now_ns, max_age);
    }
    const Real force = static_cast<Real>(frame[Input::kForce].value);
    c |= Check(frame[Input::kForce], force, now_ns, max_age);
    if (c == 0) {
      clipped_volts = clipped_.Update(accel, force);
      const Real* xh = clipped_.estimate();
      bool finite = std::isfinite(clipped_.desired_force());
      for (int i = 0; i < ClippedOptimal::kStates; ++i) finite = finite && std::isfinite(xh[i]);
      if (!finite) {
        clipped_.Reset();
        c |= Watchdog::Bit(FaultCause::kNonFinite);
      }
    } else {
      clipped_.Reset();
    }
    causes |= c;
  }

  // The model's force was non-finite last period (it was reset): its next inversions start
  // from a cleared history, and a model that diverges every period would do so for ever.
  if (model_diverged_) causes |= Watchdog::Bit(FaultCause::kNonFinite);

  ControllerOutput out;
  out.causes = causes;
  out.safe = watchdog_.Update(causes);
  runtime_.Begin(v_, x_);
  Real volts = safe_voltage_;
  law_volts_ = std::numeric_limits<double>::quiet_NaN();
  if (!out.safe && config_.law.mode == ControlMode::kClippedOptimal) {
    const Real fc = clipped_.desired_force();
    out.force_demand = static_cast<double>(fc);
    if (config_.law.clipped_command == ClippedCommand::kInverse) {
      const Real limit = static_cast<Real>(config_.law.force_limit);
      const Inverter::Solution s =
          inverter_.Solve(runtime_.history(), std::fmin(std::fmax(fc, -limit), limit), v_);
      volts = s.E;
      law_volts_ = static_cast<double>(s.E);
      out.force_law = true;
      SetInversion(s, &out);
    } else {
      law_volts_ = static_cast<double>(clipped_volts);
      volts = std::fmin(std::fmax(clipped_volts, e_min_), e_max_);
    }
  } else if (!out.safe) {
    const ControlOutput law =
        law_.Update({v_, demand, body_velocity, wheel_velocity, body_acceleration});
    if (law.is_force) {
      const Inverter::Solution s = inverter_.Solve(runtime_.history(), law.value, v_);
      volts = s.E;
      law_volts_ = static_cast<double>(s.E);
      out.force_demand = static_cast<double>(law.value);
      out.force_law = true;
      SetInversion(s, &out);
    } else {
      law_volts_ = static_cast<double>(law.value);
      volts = std::fmin(std::fmax(law.value, e_min_), e_max_);
    }
  }
  const Real model_force = runtime_.Finish(volts);
  out.volts = static_cast<double>(volts);
  out.model_force = static_cast<double>(model_force);
  model_diverged_ = !std::isfinite(model_force);
  if (model_diverged_) {  // a diverging model must not poison later periods
    runtime_.Reset();
    ++model_resets_;
  }
  return out;
}

}  // namespace mrd::firmware
