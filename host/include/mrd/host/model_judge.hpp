#pragma once
// Judging a model on data: physical units of the toolkit's signals, the name of J's
// weighting, and the operating-envelope (range) check of the inputs. Used wherever a model
// meets data: `mrd simulate`, `mrd report`, `mrd compare`, `mrd resid`.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrd/host/csv.hpp"
#include "mrd/host/model_file.hpp"

namespace mrd::host {

// Unit of a toolkit signal ("N" for f, "cm/s" for v, "cm" for x, "V" for E, "s" for t); ""
// for any other name.
std::string SignalUnit(const std::string& name);
// "12.5 N" / "12.5" (no unit): a value with its unit, %.4g.
std::string WithUnit(double value, const std::string& name);

// J's weighting in words, e.g. "relative weighting 1/max(|f_n|, 0.1), normalised f" or
// "unweighted MSE of normalised f" (f_n = (f - offset) / scale of the model's channel).
std::string CostWeightingName(const ModelFile& m);
// Short form for table headers: "rel, floor 0.1" / "mse".
std::string CostWeightingShort(const ModelFile& m);

// Operating-envelope check of one input channel: the model's identification envelope
// [env_min, env_max] (raw units) against the data's samples.
struct EnvelopeCheck {
  std::string channel;
  std::string unit;  // SignalUnit(channel), may be ""
  double env_min = 0.0, env_max = 0.0;
  double data_min = 0.0, data_max = 0.0;
  std::size_t samples = 0;       // rows of the data file
  std::size_t outside = 0;       // samples below env_min or above env_max
  double largest_excursion = 0;  // largest distance beyond the envelope (0 when inside)
  double worst_value = 0.0;      // the sample value of that excursion
  double outside_share() const {
    return samples == 0 ? 0.0 : static_cast<double>(outside) / static_cast<double>(samples);
  }
};

// Every input channel of the model (channels[1...]) that has a recorded envelope and a column
// in the data. Channels without a recorded range (older model files) are left out.
std::vector<EnvelopeCheck> CheckEnvelope(const ModelFile& m, const DataSet& data);

// One warning line per channel with samples outside ("" lines none), e.g.
// "warning: MODEL on DATA: v outside the identification envelope [-15, 15] cm/s in 31.2 % of
// samples (6240 of 20000), largest excursion 13.1 cm/s beyond (v = 28.1 cm/s)".
std::vector<std::string> EnvelopeWarnings(const std::string& model_path,
                                          const std::string& data_path,
                                          const std::vector<EnvelopeCheck>& checks);
// {"v": {"unit": "cm/s", "envelope": [lo, hi], "data": [lo, hi], "outside": n,
//        "outside_share": s, "largest_excursion": e, "worst_value": w}, ...}
nlohmann::json EnvelopeJson(const std::vector<EnvelopeCheck>& checks);
// True when any checked channel has samples outside.
bool AnyOutside(const std::vector<EnvelopeCheck>& checks);

// The metrics of SimulateModel as JSON, in physical units with the unit named:
// {"J", "J_weighting", "nrmse", "fit_percent", "rmse", "rmse_unit", "mse_physical", ...}.
nlohmann::json MetricsJson(const ModelFile& m, const SimMetrics& s);

}  // namespace mrd::host
