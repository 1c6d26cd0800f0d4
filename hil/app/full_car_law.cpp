#include "full_car_law.hpp"

#include <cmath>
#include <cstdlib>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"

namespace mrd::hil {
namespace {

constexpr const char* kModal = "modal-skyhook";

// heave=C:pitch=C:roll=C into *g; false with *error.
bool ParseModalGains(const std::string& spec, firmware::ModalGains* g, std::string* error) {
  const std::string where = "--laws '" + spec + "': ";
  std::string rest = spec.size() > std::string(kModal).size() ? spec.substr(14) : "";
  while (!rest.empty()) {
    const auto next = rest.find(':');
    const std::string kv = rest.substr(0, next);
    rest = next == std::string::npos ? "" : rest.substr(next + 1);
    const auto eq = kv.find('=');
    const std::string key = kv.substr(0, eq);
    double* out = key == "heave"   ? &g->heave_n_s_per_m
                  : key == "pitch" ? &g->pitch_n_m_s_per_rad
                  : key == "roll"  ? &g->roll_n_m_s_per_rad
                                   : nullptr;
    char* end = nullptr;
    const std::string value = eq == std::string::npos ? "" : kv.substr(eq + 1);
    const double v = std::strtod(value.c_str(), &end);
    if (out == nullptr || value.empty() || end != value.c_str() + value.size() ||
        !std::isfinite(v) || v < 0.0) {
      *error = where + "expected heave=, pitch= or roll= with a gain >= 0, got '" + kv + "'";
      return false;
    }
    *out = v;
  }
  return true;
}

}  // namespace

bool MakeFullCarLaw(const std::string& spec, double skyhook_gain, double e_max,
                    const std::string& sections, FullCarLawSpec* out, std::string* error) {
  const std::string name = spec.substr(0, spec.find(':'));
  if (name != kModal) {
    out->modal = false;
    return MakeFirmwareLaw(spec, skyhook_gain, e_max, sections, &out->law, error);
  }
  out->modal = true;
  if (!ParseModalGains(spec, &out->gains, error)) return false;
  FirmwareLaw& law = out->law;
  law.spec = spec;
  law.name = name;
  const std::string text =
      "[control]\nlaw = \"force\"\ne_max = " + std::to_string(e_max) + "\n" + sections;
  std::string why;
  if (!firmware::platform::ParseConfig(text, "", &law.config, &why)) {
    return *error = "--laws '" + spec + "': " + why, false;
  }
  law.config.controller.e_max = law.config.e_max.value_or(firmware::kBuiltinTable.e_max);
  return true;
}

bool RunFullCarLaw(const FullCarLawSpec& law, const CoefficientTable& table, FullCarPlant* plant,
                   double duration_s, double settle_s, FullCarLawRun* out, std::string* error) {
  if (!CheckFirmwareLaw(law.law, table, error)) return false;
  firmware::Controller corner[4];
  for (firmware::Controller& c : corner) (void)c.Configure(table, law.law.config.controller);
  firmware::ModalSkyhook modal;
  const FullCarParams& car = plant->params().car;
  const firmware::BodyGeometry geometry{car.cg_to_front_m, car.cg_to_rear_m, car.track_front_m,
                                        car.track_rear_m, car.motion_ratio};
  const char* why = nullptr;
  if (law.modal && modal.Configure(geometry, law.gains, &why) != Error::kOk) {
    return *error = "--laws '" + law.law.spec + "': " + why, false;
  }
  const double period = plant->period_s();
  const auto period_ns = static_cast<std::int64_t>(std::llround(period * 1e9));
  const double e_max = law.law.config.controller.e_max;
  FullCarLawRun run;
  run.ride = RunFullCarRide(
      plant, duration_s, settle_s, [&](const FullCarPlant& p, std::int64_t k, CornerValues* volts) {
        const std::int64_t now = k * period_ns;
        const FullCarSample& s = p.Sample();
        double vb[4], demand[4] = {};
        for (int i = 0; i < 4; ++i) vb[i] = 100.0 * s.corner[i].body_velocity_m_s;
        if (law.modal) modal.Demands(vb, demand);
        for (int i = 0; i < 4; ++i) {
          firmware::SensorFrame frame;
          frame[firmware::Input::kVelocity] = {s.corner[i].damper_v_cm_s, now};
          frame[firmware::Input::kDisplacement] = {s.corner[i].damper_x_cm, now};
          frame[firmware::Input::kBodyVelocity] = {vb[i], now};
          frame[firmware::Input::kBodyAcceleration] = {100.0 * p.CornerAccel(i), now};
          frame[firmware::Input::kWheelVelocity] = {100.0 * s.corner[i].wheel_velocity_m_s, now};
          frame[firmware::Input::kForce] = {p.damper_force_n()[i], now};
          frame[firmware::Input::kDemand] = {demand[i], now};
          const firmware::ControllerOutput o =
              corner[i].Update(frame, firmware::IoStatus::kOk, false, now, period);
          if (!std::isfinite(o.volts) || o.volts < 0.0 || o.volts > e_max) ++run.violations;
          if (o.safe && k > 0) ++run.safe_periods;
          (*volts)[i] = o.volts;
        }
      });
  *out = run;
  return true;
}

}  // namespace mrd::hil
