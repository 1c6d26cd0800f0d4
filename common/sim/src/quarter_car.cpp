// Quarter car (quarter_car.hpp).
//
// Default car, and why (the Spencer damper is small: at 0 V it acts like ~19 N s/cm
// (1.9 kN s/m) plus ~35 N of friction, at 2.25 V like ~25 N s/cm plus ~1.1 kN):
//   ms 300 kg, mu 40 kg, ks 20 kN/m, kt 180 kN/m: body mode sqrt(ks kt/(ks+kt)/ms)/2pi
//   = 1.2 Hz, wheel hop sqrt((ks+kt)/mu)/2pi = 11 Hz, static tyre load 3.3 kN.
//   Motion ratio 0.7 (double-wishbone-like): the damper sees 0.7 of the wheel travel and its
//   force acts 0.7-fold at the wheel, so its wheel damping is 0.49 of its own: 0 V gives
//   ~0.94 kN s/m, zeta = 0.94 / (2 sqrt(ks ms) = 4.9 kN s/m) = 0.19 (a soft passive car),
//   2.25 V gives a ~0.75 kN friction force at the wheel, enough to lock the suspension on
//   small inputs (a harsh passive car). Without the ratio (r = 1) the 0 V damper alone is
//   already zeta ~0.39 and there is little left for a semi-active law to win on comfort.
//   Travel on class C at 20 m/s stays within a few cm (the tests check the peak).
#include "mrd/sim/quarter_car.hpp"

#include <cmath>

#include "param_fields.hpp"

namespace mrd {
namespace {
constexpr double kGravity = 9.81;  // [m/s^2]
}  // namespace

bool QuarterCarParams::IsValid(const char** reason) const {
  return sim_internal::FieldsValid(
      {
          {"sprung_mass_kg", sprung_mass_kg, sprung_mass_kg > 0.0},
          {"unsprung_mass_kg", unsprung_mass_kg, unsprung_mass_kg > 0.0},
          {"spring_n_per_m", spring_n_per_m, spring_n_per_m >= 0.0},
          {"tyre_n_per_m", tyre_n_per_m, tyre_n_per_m > 0.0},
          {"motion_ratio", motion_ratio, motion_ratio > 0.0 && motion_ratio <= 1.0},
          {"speed_m_s", speed_m_s, speed_m_s >= 0.0},
          {"max_volts", max_volts, max_volts >= 0.0},
          {"substeps", static_cast<double>(substeps), substeps >= 1 && substeps <= 10000},
      },
      reason);
}

QuarterCarPlant::QuarterCarPlant(const SpencerParams& damper, const QuarterCarParams& car,
                                 const RoadParams& road, double period_s)
    : damper_(damper, 1),
      car_(car),
      road_(road),
      track_(road_, car.speed_m_s * period_s),
      period_s_(period_s),
      weight_n_((car.sprung_mass_kg + car.unsprung_mass_kg) * kGravity) {
  if (car_.substeps < 1) car_.substeps = 1;
  Reset();
}

QuarterCarPlant::Forces QuarterCarPlant::ForcesAt(const State& s, double zr) const {
  const double r = car_.motion_ratio;
  const double x = 100.0 * r * (s.zs - s.zu);
  const double xdot = 100.0 * r * (s.vs - s.vu);
  Forces f;
  f.damper = damper_.ForceAt(s.d, x, xdot);
  f.susp = -car_.spring_n_per_m * (s.zs - s.zu) - r * (f.damper - f0_);
  f.tyre = std::fmax(-weight_n_, car_.tyre_n_per_m * (zr - s.zu));
  return f;
}

QuarterCarPlant::State QuarterCarPlant::Rates(const State& s, double zr, double E) const {
  const double r = car_.motion_ratio;
  const Forces f = ForcesAt(s, zr);
  State d;
  d.zs = s.vs;
  d.vs = f.susp / car_.sprung_mass_kg;
  d.zu = s.vu;
  d.vu = (f.tyre - f.susp) / car_.unsprung_mass_kg;
  d.d = damper_.Derivative(s.d, 100.0 * r * (s.zs - s.zu), 100.0 * r * (s.vs - s.vu), E);
  return d;
}

void QuarterCarPlant::Reset() {
  steps_ = 0;
  track_.Reset(0.0);
  zr_ = track_.height_m();
  vr_ = car_.speed_m_s * track_.slope();
  state_ = State{zr_, 0.0, zr_, 0.0, SpencerState{0.0, 0.0, 0.0}};
  f0_ = 0.0;
  f0_ = damper_.ForceAt(state_.d, 0.0, 0.0);  // -k1 x0: balanced by the static preload
  UpdateDetail(zr_);
}

PlantSample QuarterCarPlant::Step(double volts) {
  const double E = std::isfinite(volts) ? std::fmin(std::fmax(volts, 0.0), car_.max_volts) : 0.0;
  const double T = period_s_;
  const double zr0 = zr_, vr0 = vr_;
  track_.Advance();
  const double zr1 = track_.height_m();
  const double vr1 = car_.speed_m_s * track_.slope();
  // Road height at normalised time a in [0, 1] (cubic Hermite; its rate is not needed: the
  // tyre is a spring).
  const auto road = [&](double a) {
    const double a2 = a * a, a3 = a2 * a;
    return (2 * a3 - 3 * a2 + 1) * zr0 + (a3 - 2 * a2 + a) * T * vr0 + (-2 * a3 + 3 * a2) * zr1 +
           (a3 - a2) * T * vr1;
  };
  const auto axpy = [](const State& s, double h, const State& d) {
    return State{s.zs + h * d.zs, s.vs + h * d.vs, s.zu + h * d.zu, s.vu + h * d.vu,
                 SpencerState{s.d.y + h * d.d.y, s.d.z + h * d.d.z, s.d.u + h * d.d.u}};
  };
  const int n = car_.substeps;
  const double h = T / n;
  State s = state_;
  for (int i = 0; i < n; ++i) {
    const double a = static_cast<double>(i) / n;
    const double ra = road(a), rm = road(a + 0.5 / n), rb = road(a + 1.0 / n);
    const State k1 = Rates(s, ra, E);
    const State k2 = Rates(axpy(s, 0.5 * h, k1), rm, E);
    const State k3 = Rates(axpy(s, 0.5 * h, k2), rm, E);
    const State k4 = Rates(axpy(s, h, k3), rb, E);
    State sum = axpy(axpy(k1, 2.0, k2), 2.0, k3);
    sum = axpy(sum, 1.0, k4);
    s = axpy(s, h / 6.0, sum);
  }
  state_ = s;
  ++steps_;
  zr_ = zr1;
  vr_ = vr1;
  UpdateDetail(zr_);
  return detail_.plant;
}

void QuarterCarPlant::UpdateDetail(double zr) {
  const State& s = state_;
  const Forces f = ForcesAt(s, zr);
  const double r = car_.motion_ratio;
  QuarterCarSample& o = detail_;
  o.plant.t_s = static_cast<double>(steps_) * period_s_;
  o.plant.x = 100.0 * r * (s.zs - s.zu);
  o.plant.v = 100.0 * r * (s.vs - s.vu);
  o.plant.demand = 0.0;
  o.plant.body_velocity = 100.0 * s.vs;
  o.plant.force = f.damper;
  o.body_accel = f.susp / car_.sprung_mass_kg;
  o.plant.body_acceleration = 100.0 * o.body_accel;
  o.plant.wheel_velocity = 100.0 * s.vu;
  o.plant.has_chassis = true;
  o.travel_cm = 100.0 * (s.zs - s.zu);
  o.tyre_load_n = f.tyre;
  o.road_m = zr;
  o.distance_m = car_.speed_m_s * o.plant.t_s;
  o.airborne = f.tyre <= -weight_n_;
}

void RideMetrics::Add(const QuarterCarSample& s) {
  ++n_;
  acc2_ += s.body_accel * s.body_accel;
  travel2_ += s.travel_cm * s.travel_cm;
  tyre2_ += s.tyre_load_n * s.tyre_load_n;
  max_travel_ = std::fmax(max_travel_, std::fabs(s.travel_cm));
  max_force_ = std::fmax(max_force_, std::fabs(s.plant.force));
  v2_ += s.plant.v * s.plant.v;
  max_v_ = std::fmax(max_v_, std::fabs(s.plant.v));
  if (s.airborne) ++lift_off_;
}

double RideMetrics::body_accel_rms() const {
  return n_ ? std::sqrt(acc2_ / static_cast<double>(n_)) : 0.0;
}
double RideMetrics::travel_rms_cm() const {
  return n_ ? std::sqrt(travel2_ / static_cast<double>(n_)) : 0.0;
}
double RideMetrics::tyre_load_rms_n() const {
  return n_ ? std::sqrt(tyre2_ / static_cast<double>(n_)) : 0.0;
}
double RideMetrics::damper_velocity_rms() const {
  return n_ ? std::sqrt(v2_ / static_cast<double>(n_)) : 0.0;
}

RideMetrics RunConstantVoltage(QuarterCarPlant* plant, double volts, double duration_s,
                               double settle_s) {
  plant->Reset();
  RideMetrics m;
  const auto steps = static_cast<std::uint64_t>(std::llround(duration_s / plant->period_s()));
  for (std::uint64_t k = 0; k < steps; ++k) {
    plant->Step(volts);
    if (plant->Detail().plant.t_s > settle_s) m.Add(plant->Detail());
  }
  return m;
}

}  // namespace mrd
