#include "mrd/firmware/sim/simulated_damper.hpp"

namespace mrd::firmware {
namespace {
constexpr std::int64_t kMaxCatchUp = 1000;  // periods per Read
}  // namespace

SimulatedDamper::SimulatedDamper(const SpencerParams& params, const SimulationConfig& config,
                                 Clock& clock, std::int64_t period_ns)
    : plant_(params, config, static_cast<double>(period_ns) * 1e-9),
      clock_(clock),
      period_ns_(period_ns),
      plant_ns_(clock.Now()),
      sample_(plant_.Sample()) {}

void SimulatedDamper::Advance(std::int64_t to_ns) {
  std::int64_t steps = (to_ns - plant_ns_) / period_ns_;
  if (steps > kMaxCatchUp) {  // a long stall: skip ahead instead of integrating it all
    plant_ns_ += (steps - kMaxCatchUp) * period_ns_;
    steps = kMaxCatchUp;
  }
  for (std::int64_t i = 0; i < steps; ++i) {
    sample_ = plant_.Step(volts_);
    plant_ns_ += period_ns_;
  }
}

IoStatus SimulatedDamper::Read(const IoTime& t, SensorFrame* frame) {
  (void)t;  // the plant runs on the loop's clock, read here as before (a bare Tick in tests)
  Advance(clock_.Now());
  (*frame)[Input::kDisplacement] = {sample_.x, plant_ns_};
  (*frame)[Input::kVelocity] = {sample_.v, plant_ns_};
  (*frame)[Input::kDemand] = {sample_.demand, plant_ns_};
  (*frame)[Input::kBodyVelocity] = {sample_.body_velocity, plant_ns_};
  (*frame)[Input::kForce] = {sample_.force, plant_ns_};
  (*frame)[Input::kBodyAcceleration] = {sample_.body_acceleration, plant_ns_};
  (*frame)[Input::kWheelVelocity] = {sample_.wheel_velocity, plant_ns_};
  for (int i = 0; i < 3; ++i) {
    (*frame)[FloorAcceleration(i)] = {sample_.floor_acceleration[i], plant_ns_};
  }
  frame->fault_line = false;
  return IoStatus::kOk;
}

IoStatus SimulatedDamper::Command(const IoTime& t, double volts) {
  (void)t;
  volts_ = volts;
  safe_ = false;
  ++commands_;
  return IoStatus::kOk;
}

IoStatus SimulatedDamper::EnterSafeState(const IoTime& t, double safe_volts) {
  (void)t;
  volts_ = safe_volts;
  safe_ = true;
  ++commands_;
  return IoStatus::kOk;
}

}  // namespace mrd::firmware
