#include "firmware_law.hpp"

#include <cmath>
#include <cstdlib>

#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/controller.hpp"
#include "mrd/firmware/platform/runtime_params.hpp"

namespace mrd::hil {
namespace {

// A value as TOML: numbers, booleans and quoted strings as they are, any other word quoted.
std::string TomlValue(const std::string& v) {
  if (v == "true" || v == "false" || (!v.empty() && v.front() == '"')) return v;
  char* end = nullptr;
  std::strtod(v.c_str(), &end);
  if (!v.empty() && end == v.c_str() + v.size()) return v;
  return "\"" + v + "\"";
}

}  // namespace

bool MakeFirmwareLaw(const std::string& spec, double skyhook_gain, double e_max,
                     const std::string& sections, FirmwareLaw* out, std::string* error) {
  const std::string where = "--laws '" + spec + "': ";
  std::string rest = spec;
  const auto colon = rest.find(':');
  out->spec = spec;
  out->name = rest.substr(0, colon);
  if (out->name.empty()) return *error = where + "empty law name", false;
  std::string control = "law = " + TomlValue(out->name) + "\n";
  std::string other;
  bool gain_set = false;
  rest = colon == std::string::npos ? "" : rest.substr(colon + 1);
  while (!rest.empty() || colon != std::string::npos) {
    const auto next = rest.find(':');
    const std::string kv = rest.substr(0, next);
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == kv.size()) {
      return *error = where + "expected KEY=VALUE after the law name, got '" + kv + "'", false;
    }
    const std::string key = kv.substr(0, eq), value = TomlValue(kv.substr(eq + 1));
    const auto dot = key.find('.');
    if (dot == std::string::npos) {
      control += key + " = " + value + "\n";
      gain_set = gain_set || key == "skyhook_gain";
    } else {
      // Appended piecewise: GCC 12 reports a false -Wrestrict on the chained operator+ here.
      other.append("[").append(key, 0, dot).append("]\n");
      other.append(key, dot + 1, std::string::npos).append(" = ").append(value).append("\n");
    }
    if (next == std::string::npos) break;
    rest = rest.substr(next + 1);
  }
  if (!gain_set) control += "skyhook_gain = " + std::to_string(skyhook_gain) + "\n";
  control += "e_max = " + std::to_string(e_max) + "\n";
  const std::string text = "[control]\n" + control + other + sections;
  std::string why;
  if (!firmware::platform::ParseConfig(text, "", &out->config, &why)) {
    // "SOURCE:LINE: reason" of the generated text: the reason alone.
    const auto at = why.find(": ");
    return *error = where + (at == std::string::npos ? why : why.substr(at + 2)), false;
  }
  const firmware::ControlMode mode = out->config.controller.law.mode;
  if (mode == firmware::ControlMode::kForceTracking || mode == firmware::ControlMode::kOpenLoop) {
    return *error = where + "law '" + out->name +
                    "' needs a force demand or voltage input, which a quarter car does not give",
           false;
  }
  out->config.controller.e_max = out->config.e_max.value_or(firmware::kBuiltinTable.e_max);
  return true;
}

bool CheckFirmwareLaw(const FirmwareLaw& law, const CoefficientTable& table, std::string* error) {
  firmware::Controller controller;
  const firmware::ConfigureStatus st = controller.Configure(table, law.config.controller);
  if (st.ok()) return true;
  *error = "--laws '" + law.spec + "': the firmware refuses it with this table: " +
           firmware::platform::DescribeConfigureRefusal(st, table, law.config.controller);
  return false;
}

bool RunFirmwareLaw(const FirmwareLaw& law, const CoefficientTable& table, QuarterCarPlant* plant,
                    double duration_s, double settle_s, LawRun* out, std::string* error) {
  firmware::Controller controller;
  if (!CheckFirmwareLaw(law, table, error)) return false;
  (void)controller.Configure(table, law.config.controller);
  const double period = plant->period_s();
  const auto period_ns = static_cast<std::int64_t>(std::llround(period * 1e9));
  const double e_max = law.config.controller.e_max;
  LawRun run;
  run.ride = RunRide(plant, duration_s, settle_s, [&](const PlantSample& s, std::int64_t k) {
    const std::int64_t now = k * period_ns;
    firmware::SensorFrame frame;
    frame[firmware::Input::kVelocity] = {s.v, now};
    frame[firmware::Input::kDisplacement] = {s.x, now};
    frame[firmware::Input::kBodyVelocity] = {s.body_velocity, now};
    frame[firmware::Input::kBodyAcceleration] = {s.body_acceleration, now};
    frame[firmware::Input::kWheelVelocity] = {s.wheel_velocity, now};
    frame[firmware::Input::kForce] = {s.force, now};
    const firmware::ControllerOutput o =
        controller.Update(frame, firmware::IoStatus::kOk, false, now, period);
    if (!std::isfinite(o.volts) || o.volts < 0.0 || o.volts > e_max) ++run.violations;
    if (o.safe && k > 0) ++run.safe_periods;
    return o.volts;
  });
  *out = run;
  return true;
}

}  // namespace mrd::hil
