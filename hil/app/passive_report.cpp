#include "passive_report.hpp"

#include <algorithm>
#include <sstream>

namespace mrd::hil {

nlohmann::json RidePointJson(const RidePoint& p) {
  return {{"volts", p.volts},
          {"body_accel_rms", p.body_accel_rms},
          {"body_accel_wk_rms", p.body_accel_wk_rms},
          {"tyre_load_rms_n", p.tyre_load_rms_n},
          {"travel_rms_cm", p.travel_rms_cm},
          {"samples", p.samples},
          {"lift_off", p.lift_off}};
}

nlohmann::json WkAtHoldingJson(const std::vector<RidePoint>& grid, const PassiveComparison& c) {
  if (!c.wk_at_holding) return nullptr;
  const RidePoint& p = grid[c.wk_at_holding->index];
  return {{"volts", p.volts},
          {"body_accel_wk_rms", p.body_accel_wk_rms},
          {"tyre_load_rms_n", p.tyre_load_rms_n},
          {"improvement_percent", *c.wk_at_holding_improvement}};
}

nlohmann::json PassiveJson(const PassiveBaseline& b, double e_max) {
  nlohmann::json j;
  j["step_v"] = b.step_v;
  j["e_min"] = 0.0;
  j["e_max"] = e_max;
  nlohmann::json grid = nlohmann::json::array();
  for (const RidePoint& p : b.grid) grid.push_back(RidePointJson(p));
  j["grid"] = grid;
  j["controlled"] = RidePointJson(b.controlled);
  j["controlled"]["volts"] = b.controlled.volts;  // mean applied command
  const PassiveComparison& c = b.comparison;
  for (std::size_t i = 0; i < kNumRideMetrics; ++i) {
    j["best"][RideMetricKey(kRideMetrics[i])] = {{"volts", c.best[i].volts},
                                                 {"value", c.best[i].value},
                                                 {"improvement_percent", c.improvement[i]}};
  }
  if (c.comfort_at_holding) {
    const RidePoint& p = b.grid[c.comfort_at_holding->index];
    j["comfort_at_equal_road_holding"] = {
        {"volts", p.volts},
        {"body_accel_rms", p.body_accel_rms},
        {"tyre_load_rms_n", p.tyre_load_rms_n},
        {"improvement_percent", *c.comfort_at_holding_improvement}};
  } else {
    j["comfort_at_equal_road_holding"] = nullptr;
  }
  j["wk_comfort_at_equal_road_holding"] = WkAtHoldingJson(b.grid, c);
  return j;
}

std::string PassiveText(const PassiveBaseline& b) {
  std::ostringstream o;
  o.precision(4);
  const PassiveComparison& c = b.comparison;
  o << "  best passive (" << b.grid.size() << " constant settings, step " << b.step_v
    << " V; improvement = (best - controlled) / best, + is better):\n";
  for (std::size_t i = 0; i < kNumRideMetrics; ++i) {
    const RideMetric m = kRideMetrics[i];
    o << "    " << RideMetricTitle(m) << ": best " << c.best[i].value << " at " << c.best[i].volts
      << " V, controlled " << MetricOf(b.controlled, m) << " (" << std::showpos << c.improvement[i]
      << std::noshowpos << " %)\n";
  }
  if (c.comfort_at_holding) {
    const RidePoint& p = b.grid[c.comfort_at_holding->index];
    o << "    comfort at equal road holding: best passive with tyre load RMS <= "
      << b.controlled.tyre_load_rms_n << " N is " << p.volts << " V (body acc " << p.body_accel_rms
      << " m/s^2, tyre load " << p.tyre_load_rms_n << " N); controlled body acc RMS improvement "
      << std::showpos << *c.comfort_at_holding_improvement << std::noshowpos << " %";
    if (c.wk_at_holding) {
      o << "; Wk weighted: vs " << c.wk_at_holding->value << " m/s^2 at " << c.wk_at_holding->volts
        << " V, " << std::showpos << *c.wk_at_holding_improvement << std::noshowpos << " %";
    }
    o << "\n";
  } else {
    o << "    comfort at equal road holding: none (every constant setting loads the tyre more "
         "than the controlled run's "
      << b.controlled.tyre_load_rms_n << " N)\n";
  }
  return o.str();
}

std::string GridData(const std::vector<RidePoint>& grid) {
  std::ostringstream o;
  o.precision(9);
  o << "# volts body_accel_rms body_accel_wk_rms tyre_load_rms_n travel_rms_cm\n";
  for (const RidePoint& p : grid) {
    o << p.volts << ' ' << p.body_accel_rms << ' ' << p.body_accel_wk_rms << ' '
      << p.tyre_load_rms_n << ' ' << p.travel_rms_cm << '\n';
  }
  return o.str();
}

std::string ComfortPanels(const std::string& grid_dat, const std::vector<PlotPoint>& points,
                          const std::string& title) {
  std::ostringstream o;
  o.precision(9);
  const std::string prefix = title.empty() ? "" : title + ": ";
  const auto panel = [&](const char* xlabel, int xcol, const char* what) {
    o << "set key outside below\n";
    o << "set xlabel '" << xlabel << "'\nset ylabel 'body acceleration RMS [m/s^2]'\n"
      << "set title '" << prefix << what << "'\n"
      << "plot '" << grid_dat << "' using " << xcol
      << ":2 with linespoints pt 7 ps 0.5 title 'passive (0 V .. E_max)', '' using " << xcol
      << ":2:(sprintf('%.2g V', $1)) every 10 with labels offset 1.5,0.6 notitle";
    for (const PlotPoint& p : points) {
      const double x = xcol == 4 ? p.point.tyre_load_rms_n : p.point.travel_rms_cm;
      o << ", '+' using (" << x << "):(" << p.point.body_accel_rms
        << ") every ::0::0 with points pt 5 ps 1.5 title '" << p.name << "'";
    }
    o << "\n";
  };
  panel("tyre load RMS [N]", 4, "comfort vs road holding");
  panel("suspension travel RMS [cm]", 5, "comfort vs travel");
  return o.str();
}

std::string PsdData(const PassiveBaseline& b) {
  std::ostringstream o;
  o.precision(9);
  o << "# f_hz off best controlled [(m/s^2)^2/Hz]\n";
  const std::size_t n =
      std::min({b.psd_off.f_hz.size(), b.psd_best.f_hz.size(), b.psd_controlled.f_hz.size()});
  for (std::size_t k = 1; k < n; ++k) {
    o << b.psd_controlled.f_hz[k] << ' ' << b.psd_off.density[k] << ' ' << b.psd_best.density[k]
      << ' ' << b.psd_controlled.density[k] << '\n';
  }
  return o.str();
}

}  // namespace mrd::hil
