#pragma once
// Residual analysis of a model on data (`mrd resid`, `mrd report`): the free-run residual
// e_s(k) = y(k) - ysim(k) (model fed back its own output, SimulateModel) and the one-step-ahead
// residual e_1(k) = y(k) - yhat(k|k-1) (model fed the measured past outputs), both in the
// output's raw units over the scored samples (after the warm-up rows).
//
// Correlations (normalised, sample estimates over N scored samples):
//   autocorrelation   r_ee(tau) = sum_k (e(k)-m_e)(e(k+tau)-m_e) / sum_k (e(k)-m_e)^2,
//                     tau = 0 ... max_lag (r_ee(0) = 1);
//   cross-correlation r_ue(tau) = sum_k (u(k)-m_u)(e(k+tau)-m_e) / sqrt(S_uu S_ee),
//                     tau = -max_lag ... max_lag, for each input channel u of the model.
// For a white residual independent of the inputs these stay within the 99 % band
// +-2.58/sqrt(N); the lags outside (tau != 0 for autocorrelations) are listed. A constant
// signal (zero variance) gives correlations of 0.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrd/host/csv.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/plot.hpp"

namespace mrd::host {

inline constexpr double kBand99 = 2.58;  // 99 % two-sided normal quantile

struct Correlation {
  std::string name;  // e.g. "free-run: autocorrelation", "one-step: v x residual"
  std::vector<int> lags;
  std::vector<double> r;     // r[i] at lags[i]
  std::vector<int> outside;  // lags with |r| > band (lag 0 left out of autocorrelations)
};

// Autocorrelation at lags 0...max_lag; cross-correlation at -max_lag...max_lag. band: the
// bound for `outside`. Throws std::invalid_argument for max_lag < 0, max_lag >= size, or
// signals of different lengths.
Correlation AutoCorrelation(const std::vector<double>& e, int max_lag, double band);
Correlation CrossCorrelation(const std::vector<double>& u, const std::vector<double>& e,
                             int max_lag, double band);
// Lags as compact ranges: "1-12, 15, 20-50" ("none" when empty).
std::string FormatLags(const std::vector<int>& lags);

struct ResidualAnalysis {
  std::size_t samples = 0;  // N scored samples
  int max_lag = 0;
  double band = 0.0;                       // 2.58 / sqrt(N)
  std::vector<std::string> inputs;         // input channels of the model, as in the data
  std::vector<double> free_run, one_step;  // residuals [output units]
  double rms_free_run = 0.0, rms_one_step = 0.0;
  bool diverged = false;  // the free run diverged (its residual correlations are then
                          // meaningless but still computed on the finite values)
  // [0] free-run autocorrelation, [1] one-step autocorrelation, then per input u:
  // free-run u x residual, one-step u x residual.
  std::vector<Correlation> correlations;
};

// Residuals and their correlations for iteration k of the model on the data. Throws
// InputError (data file) when max_lag is not below the number of scored samples or the data
// lacks a column; std::invalid_argument for max_lag < 1.
ResidualAnalysis AnalyseResiduals(const ModelFile& m, int k, const DataSet& data, int max_lag);

// Lags that count as short for the advice (missing dynamics show there first) [samples], and
// how far beyond the 99 % band a correlation there must be to count (chance stays inside).
inline constexpr int kShortLag = 5;
inline constexpr double kAdviceBand = 2.0;

// What the one-step correlations suggest, in words, one line each: autocorrelation at short
// lags (missing autoregressive terms), an input leading the residual at short lags (missing
// input dynamics or delays: more delays, a low_pass regressor), an input following it (the
// data are closed-loop), a diverged free run; else that nothing suggests missing dynamics.
std::vector<std::string> ResidualAdvice(const ResidualAnalysis& a);

// Text block: N, band, per correlation the largest |r| off lag 0 and the lags outside, then
// ResidualAdvice's lines ("suggests: ...").
std::string ResidualSummary(const ResidualAnalysis& a, const std::string& output_unit);
nlohmann::json ResidualJson(const ResidualAnalysis& a);
// Figure: one column per residual (free run, one step), rows: autocorrelation, then one
// cross-correlation per input; the band drawn as dashed lines.
PlotFigure ResidualPlot(const ResidualAnalysis& a, const std::string& title);

}  // namespace mrd::host
