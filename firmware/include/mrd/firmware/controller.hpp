#pragma once
// The per-period control computation, without I/O: watchdog, velocity, control law, model
// inversion and model update, in that order. The loop (loop.hpp) feeds it what the sensors
// delivered and sends its command to the driver.
//
//   causes  = stale/non-finite required inputs | bus fault | driver fault | fault line
//             | velocity or a measured displacement beyond its plausibility limit
//             | the model's force non-finite last period (non_finite; the model is reset)
//   safe    = watchdog(causes)
//   E(k)    = safe ? E_safe
//                  : law gives a voltage ? clamp(voltage, E_min, E_max)
//                  : inverse of the model at the force demand (inverter.hpp): E_min for a
//                    demand of 0 or of the sign opposite to v, else the lowest command
//                    whose force is nearest the demand
//   clipped-optimal: its observer updates every period its inputs (three floor accelerations,
//             the measured force) are fresh and finite, safe or not; a period where one is not
//             restarts the estimate from rest (and raises the watchdog cause)
//   f^(k)   = model(v(k), x(k), E(k))   (the model advances with the command actually sent)
//
// Invalid inputs never reach the model: it runs on the last valid velocity/displacement.
// Per-sample arithmetic in Real (real.hpp): sensor values are converted at the entry of
// Update, the outputs back to double.

#include <cstdint>
#include <memory>

#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/clipped_optimal.hpp"
#include "mrd/firmware/configure_status.hpp"
#include "mrd/firmware/control_law.hpp"
#include "mrd/firmware/inverter.hpp"
#include "mrd/firmware/io.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "mrd/firmware/shared_model.hpp"
#include "mrd/firmware/velocity.hpp"
#include "mrd/firmware/watchdog.hpp"

namespace mrd::firmware {

enum class VelocitySource : std::uint8_t {
  kMeasured = 0,  // SensorFrame::velocity
  kDisplacement,  // filtered derivative of SensorFrame::displacement
};

struct ControllerConfig {
  ControlLawConfig law;
  WatchdogConfig watchdog;
  VelocitySource velocity_source = VelocitySource::kMeasured;
  double cutoff_hz = 50.0;    // displacement differentiator cut-off [Hz]
  double e_max = 2.25;        // highest command [V], within the table's range
  double safe_voltage = 0.0;  // [V], within the table's range
  // Plausibility limits: |v| [cm/s] (measured or derived) and |x| [cm] above them are
  // implausible (a sensor fault, or far outside the range the model was identified on): safe
  // state, and the model keeps the last plausible value. 0: no limit. The displacement limit
  // holds whenever a displacement is measured (sampled at least once), used or not; with no
  // displacement measured there is nothing to check (the config refuses the limit then).
  double velocity_limit = 0.0;
  double displacement_limit = 0.0;
  // Operating envelope of the table (version 2): the model's v, x and fed-back force are held
  // to the identification data's range widened by envelope_margin (fraction of the range)
  // on each side, and the excursions counted (model_runtime.hpp). No effect on a table
  // without an envelope.
  bool envelope = true;
  double envelope_margin = 0.1;
  // law kClippedOptimal: the gains of the off-line design (mrd-structure design; the config's
  // [clipped_optimal] gains file). Configure refuses the law without valid loaded gains.
  ClippedOptimalGains clipped_gains;
  bool clipped_gains_loaded = false;
};

struct ControllerOutput {
  double volts = 0.0;         // command [V]
  bool safe = true;           // send as EnterSafeState(volts)
  double model_force = 0.0;   // model force at the command [N]
  double force_demand = 0.0;  // force the law asked for [N] (0 for a voltage law)
  bool force_law = false;     // the law produced a force demand this period
  bool reachable = true;      // the force demand was reachable (false: saturated)
  // Force laws: the demand was 0 or of the sign opposite to v (E_min commanded by rule); the
  // model was monotone in E over [E_min, E_max] at the period's state (inverter.hpp).
  bool passive = false;
  bool monotone = true;
  std::uint32_t causes = 0;  // active watchdog causes (Watchdog::Bit)
};

class Controller {
 public:
  Controller() = default;
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;

  // Binds a table and a configuration. Refusals (configure_status.hpp) carry the reason and
  // the code: kTable with the table's error (Validate, kInvalidArgument for a channel the
  // firmware does not provide, kNotInvertible), every other reason kOutOfRange. Not real-time.
  ConfigureStatus Configure(const CoefficientTable& table, const ControllerConfig& config);
  // The same on a loaded model shared with the other channels running its table
  // (shared_model.hpp; non-null): one copy of the model for all of them, the history, filter
  // and watchdog this controller's. Not real-time.
  ConfigureStatus Configure(std::shared_ptr<const SharedModel> model,
                            const ControllerConfig& config);
  // Retunes a configured controller to `config` (law, E_max, limits, recovery, cut-off,
  // envelope) keeping the model's history, the filter and the watchdog's state and counters.
  // The same checks as Configure against the bound table; kOutOfRange (a value Configure would
  // refuse) or kInvalidArgument (a key a retune cannot change: velocity source, safe voltage,
  // sensor max age) change nothing. Real-time safe (a period boundary).
  Error Retune(const ControllerConfig& config);
  // Clears model history, filter and watchdog. Real-time safe.
  void Reset();
  // One period. frame: latest sensor values; read_status: what Read returned; driver_fault:
  // the last driver write failed; now_ns: this period's time (same clock as the stamps);
  // dt_s: clamped period [s] for the differentiator. Real-time safe.
  ControllerOutput Update(const SensorFrame& frame, IoStatus read_status, bool driver_fault,
                          std::int64_t now_ns, double dt_s);

  const Watchdog& watchdog() const { return watchdog_; }
  const ModelRuntime& runtime() const { return runtime_; }
  const ControllerConfig& config() const { return config_; }
  std::uint64_t model_resets() const { return model_resets_; }
  // Periods whose velocity or displacement was held to the envelope; periods whose model force
  // was held to the force envelope.
  std::uint64_t input_excursions() const { return runtime_.input_excursions(); }
  std::uint64_t force_excursions() const { return runtime_.force_excursions(); }
  // The last period's v [cm/s] and x [cm] as the model ran on them (last valid, held to the
  // envelope), and the law's command before the safe state: the inverse of the model at the
  // force demand (force laws), or the law's voltage before clamping to [E_min, E_max] [V];
  // NaN in the safe state (the law did not run).
  double v_used() const { return static_cast<double>(runtime_.held_v()); }
  double x_used() const { return static_cast<double>(runtime_.held_x()); }
  double law_volts() const { return law_volts_; }
  // The clipped-optimal law's object (estimate, desired force); idle under the other laws.
  const ClippedOptimal& clipped_optimal() const { return clipped_; }

 private:
  ModelRuntime runtime_;
  Inverter inverter_;
  ControlLaw law_;
  ClippedOptimal clipped_;
  Watchdog watchdog_;
  DisplacementDifferentiator differentiator_;
  ControllerConfig config_;
  double table_e_min_ = 0.0;  // the bound table's command range [V]
  double table_e_max_ = 0.0;
  Real e_min_ = Real(0);  // config_ in Real
  Real e_max_ = Real(0);
  Real safe_voltage_ = Real(0);
  Real velocity_limit_ = Real(0);
  Real displacement_limit_ = Real(0);
  Real v_ = Real(0);  // last valid velocity [cm/s]
  Real x_ = Real(0);  // last valid displacement [cm]
  std::uint64_t model_resets_ = 0;
  bool model_diverged_ = false;  // the model force was non-finite last period
  double law_volts_ = 0.0;       // law_volts()
};

}  // namespace mrd::firmware
