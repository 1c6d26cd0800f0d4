#include "mrd/firmware/controller.hpp"

#include <cmath>
#include <limits>
#include <utility>

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

// Gains the clipped-optimal law can run on: loaded and valid, when the law is selected, and of
// a one-damper design (the controller drives one damper; a design for several needs them all).
bool ClippedGainsOk(const ControllerConfig& c) {
  return c.law.mode != ControlMode::kClippedOptimal ||
         (c.clipped_gains_loaded && c.clipped_gains.IsValid(nullptr) &&
          c.clipped_gains.dampers == 1);
}

// The inversion's verdicts on the period's force demand.
void SetInversion(const Inverter::Solution& s, ControllerOutput* out) {
  out->reachable = s.reachable;
  out->passive = s.passive;
  out->monotone = s.monotone;
}

// True when a finite value exceeds a limit (limit 0: none).
bool Implausible(Real value, Real limit) { return limit > Real(0) && std::fabs(value) > limit; }

// ---- Update's steps ----------------------------------------------------------------------
// 1. Input checks: the devices' causes, then each signal's staleness and plausibility where
//    it is read (EstimateMotion, LawInputCauses, Observe).

// Causes the devices report: the buses that named themselves (else a read fault of a source
// that names no bus), the driver's failed write, the external fault line.
std::uint32_t DeviceCauses(const SensorFrame& frame, IoStatus read_status, bool driver_fault) {
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
  if (frame.peer_fault) causes |= Watchdog::Bit(FaultCause::kOtherChannel);
  return causes;
}

// The law's signals this period in Real, at the model's velocity v [cm/s].
ControlInputs LawInputs(const SensorFrame& frame, Real v) {
  const auto value = [&frame](Input i) { return static_cast<Real>(frame[i].value); };
  return {v, value(Input::kDemand), value(Input::kBodyVelocity), value(Input::kWheelVelocity),
          value(Input::kBodyAcceleration)};
}

// Causes of the signals the law reads (in: their values in Real): stale or non-finite.
std::uint32_t LawInputCauses(const ControlLaw& law, const SensorFrame& frame,
                             const ControlInputs& in, std::int64_t now_ns, std::int64_t max_age) {
  std::uint32_t causes = 0;
  if (law.needs_demand()) causes |= Check(frame[Input::kDemand], in.demand, now_ns, max_age);
  if (law.needs_body_velocity()) {
    causes |= Check(frame[Input::kBodyVelocity], in.body_velocity, now_ns, max_age);
  }
  if (law.needs_wheel_velocity()) {
    causes |= Check(frame[Input::kWheelVelocity], in.wheel_velocity, now_ns, max_age);
  }
  if (law.needs_body_acceleration()) {
    causes |= Check(frame[Input::kBodyAcceleration], in.body_acceleration, now_ns, max_age);
  }
  return causes;
}

// 2. Velocity estimation.

// Where the model's motion comes from: the velocity's source, whether the model reads the
// displacement, the plausibility limits (0: none), the samples' max age [ns].
struct MotionSetup {
  VelocitySource source;
  bool model_reads_x;
  Real velocity_limit;
  Real displacement_limit;
  std::int64_t max_age_ns;
};

// The model's velocity *v [cm/s] and displacement *x [cm]: the measured velocity, or the
// filtered derivative (*diff, over dt_s [s]) of the displacement, each kept at its last valid
// value when the period's is non-finite or implausible. Returns the causes of the signals it
// reads (stale, non-finite, implausible); a displacement measured though unused must still
// be plausible.
std::uint32_t EstimateMotion(const SensorFrame& frame, const MotionSetup& s, std::int64_t now_ns,
                             double dt_s, DisplacementDifferentiator* diff, Real* v, Real* x) {
  constexpr std::uint32_t kImplausibleBit = Watchdog::Bit(FaultCause::kImplausible);
  const Real velocity = static_cast<Real>(frame[Input::kVelocity].value);
  const Real displacement = static_cast<Real>(frame[Input::kDisplacement].value);
  std::uint32_t causes = 0;
  if (s.source == VelocitySource::kMeasured) {
    causes |= Check(frame[Input::kVelocity], velocity, now_ns, s.max_age_ns);
    if (Implausible(velocity, s.velocity_limit)) {
      causes |= kImplausibleBit;
    } else if (std::isfinite(velocity)) {
      *v = velocity;
    }
  }
  if (s.source == VelocitySource::kDisplacement || s.model_reads_x) {
    causes |= Check(frame[Input::kDisplacement], displacement, now_ns, s.max_age_ns);
    if (Implausible(displacement, s.displacement_limit)) {
      causes |= kImplausibleBit;
    } else if (std::isfinite(displacement)) {
      *x = displacement;
      if (s.source == VelocitySource::kDisplacement) {
        const Real derived = diff->Update(*x, static_cast<Real>(dt_s));
        if (Implausible(derived, s.velocity_limit)) {
          causes |= kImplausibleBit;
        } else {
          *v = derived;
        }
      }
    }
  } else if (Measured(frame[Input::kDisplacement]) &&
             Implausible(displacement, s.displacement_limit)) {
    // Measured though neither the model nor the velocity reads it: the limit still holds.
    causes |= kImplausibleBit;
  }
  return causes;
}

// 3. The clipped-optimal observer: it runs on fresh, finite inputs (three floor
//    accelerations, the measured force; safe or not), its command in *volts; otherwise its
//    estimate restarts from rest. An estimate that turns non-finite is reset (non_finite).
//    Returns the causes.
std::uint32_t Observe(const SensorFrame& frame, std::int64_t now_ns, std::int64_t max_age,
                      ClippedOptimal* clipped, Real* volts) {
  Real accel[3];
  std::uint32_t c = 0;
  for (int i = 0; i < 3; ++i) {
    accel[i] = static_cast<Real>(frame[FloorAcceleration(i)].value);
    c |= Check(frame[FloorAcceleration(i)], accel[i], now_ns, max_age);
  }
  const Real force = static_cast<Real>(frame[Input::kForce].value);
  c |= Check(frame[Input::kForce], force, now_ns, max_age);
  if (c != 0) {
    clipped->Reset();
    return c;
  }
  *volts = clipped->Update(accel, force);
  const Real* xh = clipped->estimate();
  bool finite = std::isfinite(clipped->desired_force());
  for (int i = 0; i < ClippedOptimal::kStates; ++i) finite = finite && std::isfinite(xh[i]);
  if (!finite) {
    clipped->Reset();
    c |= Watchdog::Bit(FaultCause::kNonFinite);
  }
  return c;
}

// 4. Law dispatch and inversion (outside the safe state).

// What turns a demand into a command: the inverter on the model's history at velocity v
// [cm/s], and the command range [e_min, e_max] [V].
struct Actuation {
  const Inverter& inverter;
  const BasicRegressorHistory<Real>& history;
  Real v;
  Real e_min;
  Real e_max;
};

// The command sent [V] and the law's before clamping (Controller::law_volts).
struct Command {
  Real volts;
  double law_volts;
};

// A force demand [N]: the model's inverse at it, its verdicts in out.
Command InvertForce(const Actuation& a, Real force, ControllerOutput* out) {
  const Inverter::Solution s = a.inverter.Solve(a.history, force, a.v);
  out->force_law = true;
  SetInversion(s, out);
  return {s.E, static_cast<double>(s.E)};
}

// A voltage demand [V], clamped to the command range.
Command ClampVolts(const Actuation& a, Real volts) {
  return {std::fmin(std::fmax(volts, a.e_min), a.e_max), static_cast<double>(volts)};
}

// The clipped-optimal law: its desired force fc [N] held to +-force_limit and inverted, or
// the observer's own command observer_volts [V].
Command ClippedOptimalCommand(const ControlLawConfig& law, Real fc, Real observer_volts,
                              const Actuation& a, ControllerOutput* out) {
  out->force_demand = static_cast<double>(fc);
  if (law.clipped_command != ClippedCommand::kInverse) return ClampVolts(a, observer_volts);
  const Real limit = static_cast<Real>(law.force_limit);
  return InvertForce(a, std::fmin(std::fmax(fc, -limit), limit), out);
}

// Every other law (a pure object): a force demand inverted, or a voltage clamped.
Command LawCommand(const ControlLaw& law, const ControlInputs& in, const Actuation& a,
                   ControllerOutput* out) {
  const ControlOutput demand = law.Update(in);
  if (!demand.is_force) return ClampVolts(a, demand.value);
  out->force_demand = static_cast<double>(demand.value);
  return InvertForce(a, demand.value, out);
}

}  // namespace

ConfigureStatus Controller::Configure(const CoefficientTable& table,
                                      const ControllerConfig& config) {
  Error e = Error::kOk;
  auto model = SharedModel::Load(table, &e);
  if (e != Error::kOk) return ConfigureStatus{ConfigureFault::kTable, e};
  return Configure(std::move(model), config);
}

ConfigureStatus Controller::Configure(std::shared_ptr<const SharedModel> model,
                                      const ControllerConfig& config) {
  const auto refuse = [](ConfigureFault fault, Error e = Error::kOutOfRange) {
    return ConfigureStatus{fault, e};
  };
  const CoefficientTable& table = model->table();
  Error e = runtime_.Configure(model);
  if (e != Error::kOk) return refuse(ConfigureFault::kTable, e);
  e = inverter_.Configure(std::move(model));
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
  const MotionSetup motion{config_.velocity_source, runtime_.reads_displacement(), velocity_limit_,
                           displacement_limit_, max_age};
  // Checks and estimation: the causes of this period; v_, x_ the last valid motion.
  std::uint32_t causes = DeviceCauses(frame, read_status, driver_fault);
  causes |= EstimateMotion(frame, motion, now_ns, dt_s, &differentiator_, &v_, &x_);
  const ControlInputs law_in = LawInputs(frame, v_);
  causes |= LawInputCauses(law_, frame, law_in, now_ns, max_age);
  Real observer_volts = e_min_;  // the observer's command (E_min when it did not run)
  if (config_.law.mode == ControlMode::kClippedOptimal) {
    causes |= Observe(frame, now_ns, max_age, &clipped_, &observer_volts);
  }
  // The model's force was non-finite last period (it was reset): its next inversions start
  // from a cleared history, and a model that diverges every period would do so for ever.
  if (model_diverged_) causes |= Watchdog::Bit(FaultCause::kNonFinite);

  // Watchdog, then the law's command and its inversion (outside the safe state).
  ControllerOutput out;
  out.causes = causes;
  out.safe = watchdog_.Update(causes);
  runtime_.Begin(v_, x_);
  Command command{safe_voltage_, std::numeric_limits<double>::quiet_NaN()};
  if (!out.safe) {
    const Actuation a{inverter_, runtime_.history(), v_, e_min_, e_max_};
    command =
        config_.law.mode == ControlMode::kClippedOptimal
            ? ClippedOptimalCommand(config_.law, clipped_.desired_force(), observer_volts, a, &out)
            : LawCommand(law_, law_in, a, &out);
  }
  law_volts_ = command.law_volts;
  // The model advances with the command actually sent.
  const Real model_force = runtime_.Finish(command.volts);
  out.volts = static_cast<double>(command.volts);
  out.model_force = static_cast<double>(model_force);
  model_diverged_ = !std::isfinite(model_force);
  if (model_diverged_) {  // a diverging model must not poison later periods
    runtime_.Reset();
    ++model_resets_;
  }
  return out;
}

}  // namespace mrd::firmware
