#pragma once
// The best passive baseline in `mrd-hil run`'s summary (JSON "passive", text lines) and its
// plots: comfort.png (body acceleration RMS against tyre-load RMS and against suspension
// travel RMS: the passive curve, one point per constant voltage, and the controlled run) and
// psd.png (Welch PSD of the body acceleration: passive-off, best passive, controlled).

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrd/hil/study/passive_baseline.hpp"

namespace mrd::hil {

nlohmann::json RidePointJson(const RidePoint& p);
// The Wk-weighted comfort at equal road holding (null when no setting qualifies).
nlohmann::json WkAtHoldingJson(const std::vector<RidePoint>& grid, const PassiveComparison& c);
nlohmann::json PassiveJson(const PassiveBaseline& b, double e_max);
std::string PassiveText(const PassiveBaseline& b);

// Gnuplot data of a passive grid: "volts body wk tyre travel" per line.
std::string GridData(const std::vector<RidePoint>& grid);
// A named point for the comfort plot (a controlled run or a law).
struct PlotPoint {
  std::string name;
  RidePoint point;
};
// Gnuplot commands (no terminal/output lines) for the two comfort panels of one case: grid_dat
// holds GridData; the points are drawn inline. title: "" for none.
std::string ComfortPanels(const std::string& grid_dat, const std::vector<PlotPoint>& points,
                          const std::string& title);
// "f off best controlled" lines over the common bins of the three PSDs (from the second bin).
std::string PsdData(const PassiveBaseline& b);

}  // namespace mrd::hil
