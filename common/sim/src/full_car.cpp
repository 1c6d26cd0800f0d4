// Full car (full_car.hpp): 7 degrees of freedom, 14 states, classical RK4.
#include "mrd/sim/full_car.hpp"

#include <cmath>

#include "param_fields.hpp"

namespace mrd {
namespace {
constexpr double kGravity = 9.81;  // [m/s^2]

bool IsFront(int corner) { return corner == kFrontLeft || corner == kFrontRight; }
bool IsLeft(int corner) { return corner == kFrontLeft || corner == kRearLeft; }

FullCar::State Axpy(const FullCar::State& s, double h, const FullCar::State& d) {
  FullCar::State o;
  o.z = s.z + h * d.z;
  o.vz = s.vz + h * d.vz;
  o.th = s.th + h * d.th;
  o.wth = s.wth + h * d.wth;
  o.ph = s.ph + h * d.ph;
  o.wph = s.wph + h * d.wph;
  for (int i = 0; i < 4; ++i) {
    o.zu[i] = s.zu[i] + h * d.zu[i];
    o.vu[i] = s.vu[i] + h * d.vu[i];
  }
  return o;
}

// 3x3 determinant of rows r0, r1, r2.
double Det3(const double m[3][3]) {
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
         m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}
}  // namespace

bool FullCarParams::IsValid(const char** reason) const {
  return sim_internal::FieldsValid(
      {
          {"body_mass_kg", body_mass_kg, body_mass_kg > 0.0},
          {"pitch_inertia_kg_m2", pitch_inertia_kg_m2, pitch_inertia_kg_m2 > 0.0},
          {"roll_inertia_kg_m2", roll_inertia_kg_m2, roll_inertia_kg_m2 > 0.0},
          {"cg_to_front_m", cg_to_front_m, cg_to_front_m > 0.0},
          {"cg_to_rear_m", cg_to_rear_m, cg_to_rear_m > 0.0},
          {"track_front_m", track_front_m, track_front_m > 0.0},
          {"track_rear_m", track_rear_m, track_rear_m > 0.0},
          {"unsprung_front_kg", unsprung_front_kg, unsprung_front_kg > 0.0},
          {"unsprung_rear_kg", unsprung_rear_kg, unsprung_rear_kg > 0.0},
          {"spring_front_n_per_m", spring_front_n_per_m, spring_front_n_per_m > 0.0},
          {"spring_rear_n_per_m", spring_rear_n_per_m, spring_rear_n_per_m > 0.0},
          {"damping_front_n_s_per_m", damping_front_n_s_per_m, damping_front_n_s_per_m >= 0.0},
          {"damping_rear_n_s_per_m", damping_rear_n_s_per_m, damping_rear_n_s_per_m >= 0.0},
          {"tyre_n_per_m", tyre_n_per_m, tyre_n_per_m > 0.0},
          {"tyre_damping_n_s_per_m", tyre_damping_n_s_per_m, tyre_damping_n_s_per_m >= 0.0},
          {"motion_ratio", motion_ratio, motion_ratio > 0.0 && motion_ratio <= 1.0},
          {"seat_x_m", seat_x_m, true},
          {"seat_y_m", seat_y_m, true},
          {"substeps", static_cast<double>(substeps), substeps >= 1 && substeps <= 10000},
      },
      reason);
}

double FullCarParams::corner_x_m(int corner) const {
  return IsFront(corner) ? cg_to_front_m : -cg_to_rear_m;
}

double FullCarParams::corner_y_m(int corner) const {
  const double t = IsFront(corner) ? track_front_m : track_rear_m;
  return IsLeft(corner) ? 0.5 * t : -0.5 * t;
}

FullCar::FullCar(const FullCarParams& params) : p_(params) {
  if (p_.substeps < 1) p_.substeps = 1;
  const double wb = p_.wheelbase_m();
  for (int i = 0; i < 4; ++i) {
    const bool front = IsFront(i);
    x_[i] = p_.corner_x_m(i);
    y_[i] = p_.corner_y_m(i);
    ks_[i] = front ? p_.spring_front_n_per_m : p_.spring_rear_n_per_m;
    cs_[i] = front ? p_.damping_front_n_s_per_m : p_.damping_rear_n_s_per_m;
    mu_[i] = front ? p_.unsprung_front_kg : p_.unsprung_rear_kg;
    // Static load: the axle's share of the body (lever rule), half per wheel, plus the wheel.
    const double axle_share = front ? p_.cg_to_rear_m / wb : p_.cg_to_front_m / wb;
    weight_[i] = (0.5 * axle_share * p_.body_mass_kg + mu_[i]) * kGravity;
  }
  Reset(CornerValues{}, CornerValues{});
}

FullCar::Rates FullCar::Derivative(const State& s, const CornerValues& zr,
                                   const CornerValues& vr) const {
  Rates r;
  double fz = 0.0, mth = 0.0, mph = 0.0;
  for (int i = 0; i < 4; ++i) {
    const double d = s.z + x_[i] * s.th + y_[i] * s.ph - s.zu[i];
    const double dv = s.vz + x_[i] * s.wth + y_[i] * s.wph - s.vu[i];
    const double fs = -ks_[i] * d - cs_[i] * dv - p_.motion_ratio * f_[i];
    const double ft = std::fmax(-weight_[i], p_.tyre_n_per_m * (zr[i] - s.zu[i]) +
                                                 p_.tyre_damping_n_s_per_m * (vr[i] - s.vu[i]));
    r.fs[i] = fs;
    r.ft[i] = ft;
    fz += fs;
    mth += x_[i] * fs;
    mph += y_[i] * fs;
    r.d.zu[i] = s.vu[i];
    r.d.vu[i] = (ft - fs) / mu_[i];
  }
  r.d.z = s.vz;
  r.d.vz = fz / p_.body_mass_kg;
  r.d.th = s.wth;
  r.d.wth = mth / p_.pitch_inertia_kg_m2;
  r.d.ph = s.wph;
  r.d.wph = mph / p_.roll_inertia_kg_m2;
  return r;
}

void FullCar::Reset(const CornerValues& road_m, const CornerValues& road_rate_m_s) {
  // Static equilibrium: each corner is ks in series with kt (k_i), pulling the body point
  // towards the road: sum_i k_i (zr_i - zb_i) (1, x_i, y_i) = 0, a 3x3 solve for (z, th, ph).
  double a[3][3] = {}, rhs[3] = {};
  CornerValues k{};
  for (int i = 0; i < 4; ++i) {
    k[i] = ks_[i] * p_.tyre_n_per_m / (ks_[i] + p_.tyre_n_per_m);
    const double g[3] = {1.0, x_[i], y_[i]};
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) a[r][c] += k[i] * g[r] * g[c];
      rhs[r] += k[i] * g[r] * road_m[i];
    }
  }
  const double det = Det3(a);
  double q[3] = {0.0, 0.0, 0.0};
  for (int c = 0; c < 3 && det != 0.0; ++c) {  // Cramer's rule
    double m[3][3];
    for (int r = 0; r < 3; ++r)
      for (int j = 0; j < 3; ++j) m[r][j] = (j == c) ? rhs[r] : a[r][j];
    q[c] = Det3(m) / det;
  }
  State s{};
  s.z = q[0];
  s.th = q[1];
  s.ph = q[2];
  for (int i = 0; i < 4; ++i) {
    const double zb = s.z + x_[i] * s.th + y_[i] * s.ph;
    s.zu[i] = (ks_[i] * zb + p_.tyre_n_per_m * road_m[i]) / (ks_[i] + p_.tyre_n_per_m);
  }
  t_s_ = 0.0;
  f_ = CornerValues{};
  SetState(s, road_m, road_rate_m_s);
}

void FullCar::SetState(const State& s, const CornerValues& road_m,
                       const CornerValues& road_rate_m_s) {
  state_ = s;
  zr_ = road_m;
  vr_ = road_rate_m_s;
  UpdateSample();
}

const FullCarSample& FullCar::Step(double dt, const CornerValues& road_m,
                                   const CornerValues& road_rate_m_s,
                                   const CornerValues& damper_n) {
  for (int i = 0; i < 4; ++i) f_[i] = std::isfinite(damper_n[i]) ? damper_n[i] : 0.0;
  const CornerValues zr0 = zr_, vr0 = vr_;
  const CornerValues& zr1 = road_m;
  const CornerValues& vr1 = road_rate_m_s;
  // Each wheel's road at normalised time u in [0, 1]: cubic Hermite height and its rate.
  const auto road = [&](double u, CornerValues* z, CornerValues* v) {
    const double u2 = u * u, u3 = u2 * u;
    const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2,
                 h11 = u3 - u2;
    const double d00 = 6 * u2 - 6 * u, d10 = 3 * u2 - 4 * u + 1, d01 = -6 * u2 + 6 * u,
                 d11 = 3 * u2 - 2 * u;
    for (int i = 0; i < 4; ++i) {
      (*z)[i] = h00 * zr0[i] + h10 * dt * vr0[i] + h01 * zr1[i] + h11 * dt * vr1[i];
      (*v)[i] = (d00 * zr0[i] + d01 * zr1[i]) / dt + d10 * vr0[i] + d11 * vr1[i];
    }
  };
  const int n = p_.substeps;
  const double h = dt / n;
  State s = state_;
  CornerValues za, va, zm, vm, zb, vb;
  for (int k = 0; k < n; ++k) {
    const double u = static_cast<double>(k) / n;
    road(u, &za, &va);
    road(u + 0.5 / n, &zm, &vm);
    road(u + 1.0 / n, &zb, &vb);
    const State k1 = Derivative(s, za, va).d;
    const State k2 = Derivative(Axpy(s, 0.5 * h, k1), zm, vm).d;
    const State k3 = Derivative(Axpy(s, 0.5 * h, k2), zm, vm).d;
    const State k4 = Derivative(Axpy(s, h, k3), zb, vb).d;
    State sum = Axpy(Axpy(k1, 2.0, k2), 2.0, k3);
    sum = Axpy(sum, 1.0, k4);
    s = Axpy(s, h / 6.0, sum);
  }
  state_ = s;
  zr_ = zr1;
  vr_ = vr1;
  t_s_ += dt;
  UpdateSample();
  return sample_;
}

double FullCar::PointAccel(double x_m, double y_m) const {
  return sample_.heave_accel + x_m * sample_.pitch_accel + y_m * sample_.roll_accel;
}

void FullCar::UpdateSample() {
  const State& s = state_;
  const Rates r = Derivative(s, zr_, vr_);
  FullCarSample& o = sample_;
  o.t_s = t_s_;
  const double ratio = p_.motion_ratio;
  for (int i = 0; i < 4; ++i) {
    FullCarCorner& c = o.corner[i];
    const double vb = s.vz + x_[i] * s.wth + y_[i] * s.wph;
    c.travel_m = s.z + x_[i] * s.th + y_[i] * s.ph - s.zu[i];
    c.travel_rate_m_s = vb - s.vu[i];
    c.damper_x_cm = 100.0 * ratio * c.travel_m;
    c.damper_v_cm_s = 100.0 * ratio * c.travel_rate_m_s;
    c.body_velocity_m_s = vb;
    c.wheel_velocity_m_s = s.vu[i];
    c.tyre_deflection_m = zr_[i] - s.zu[i];
    c.tyre_load_n = r.ft[i];
    c.damper_force_n = f_[i];
    c.airborne = r.ft[i] <= -weight_[i];
  }
  o.heave_m = s.z;
  o.heave_velocity_m_s = s.vz;
  o.heave_accel = r.d.vz;
  o.pitch_rad = s.th;
  o.pitch_rate = s.wth;
  o.pitch_accel = r.d.wth;
  o.roll_rad = s.ph;
  o.roll_rate = s.wph;
  o.roll_accel = r.d.wph;
  o.seat_accel = PointAccel(p_.seat_x_m, p_.seat_y_m);
}

}  // namespace mrd
