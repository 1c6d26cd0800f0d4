#include "mrd/host/residuals.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>

#include "mrd/host/input_error.hpp"
#include "mrd/host/model_judge.hpp"

namespace mrd::host {
namespace {

double Mean(const std::vector<double>& x) {
  double s = 0.0;
  for (const double v : x) s += v;
  return x.empty() ? 0.0 : s / static_cast<double>(x.size());
}

double CentredSumSquares(const std::vector<double>& x, double m) {
  double s = 0.0;
  for (const double v : x) s += (v - m) * (v - m);
  return s;
}

// sum_k (a(k)-ma)(b(k+tau)-mb) over the k where both exist.
double LaggedProduct(const std::vector<double>& a, double ma, const std::vector<double>& b,
                     double mb, int tau) {
  const long n = static_cast<long>(a.size());
  double s = 0.0;
  for (long k = std::max(0L, -static_cast<long>(tau)); k < n && k + tau < n; ++k) {
    s += (a[static_cast<std::size_t>(k)] - ma) * (b[static_cast<std::size_t>(k + tau)] - mb);
  }
  return s;
}

void CheckLag(std::size_t n, int max_lag) {
  if (max_lag < 0 || static_cast<std::size_t>(max_lag) >= n) {
    throw std::invalid_argument(fmt::format("max lag {} outside 0 ... {} (signal of {} samples)",
                                            max_lag, n == 0 ? 0 : static_cast<long>(n) - 1, n));
  }
}

double Rms(const std::vector<double>& x) {
  double s = 0.0;
  for (const double v : x) s += v * v;
  return x.empty() ? 0.0 : std::sqrt(s / static_cast<double>(x.size()));
}

}  // namespace

Correlation AutoCorrelation(const std::vector<double>& e, int max_lag, double band) {
  CheckLag(e.size(), max_lag);
  Correlation c;
  const double m = Mean(e);
  const double s = CentredSumSquares(e, m);
  for (int tau = 0; tau <= max_lag; ++tau) {
    const double r = s > 0.0 ? LaggedProduct(e, m, e, m, tau) / s : 0.0;
    c.lags.push_back(tau);
    c.r.push_back(r);
    if (tau != 0 && std::fabs(r) > band) c.outside.push_back(tau);
  }
  return c;
}

Correlation CrossCorrelation(const std::vector<double>& u, const std::vector<double>& e,
                             int max_lag, double band) {
  if (u.size() != e.size()) {
    throw std::invalid_argument(
        fmt::format("cross-correlation of {} and {} samples", u.size(), e.size()));
  }
  CheckLag(e.size(), max_lag);
  Correlation c;
  const double mu = Mean(u), me = Mean(e);
  const double d = std::sqrt(CentredSumSquares(u, mu) * CentredSumSquares(e, me));
  for (int tau = -max_lag; tau <= max_lag; ++tau) {
    const double r = d > 0.0 ? LaggedProduct(u, mu, e, me, tau) / d : 0.0;
    c.lags.push_back(tau);
    c.r.push_back(r);
    if (std::fabs(r) > band) c.outside.push_back(tau);
  }
  return c;
}

std::string FormatLags(const std::vector<int>& lags) {
  if (lags.empty()) return "none";
  std::string out;
  for (std::size_t i = 0; i < lags.size();) {
    std::size_t j = i;
    while (j + 1 < lags.size() && lags[j + 1] == lags[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += j == i ? fmt::format("{}", lags[i]) : fmt::format("{}...{}", lags[i], lags[j]);
    i = j + 1;
  }
  return out;
}

ResidualAnalysis AnalyseResiduals(const ModelFile& m, int k, const DataSet& data, int max_lag) {
  if (max_lag < 1) throw std::invalid_argument(fmt::format("--max-lag {}: must be >= 1", max_lag));
  ResidualAnalysis a;
  a.max_lag = max_lag;
  std::vector<double> ysim;
  const SimMetrics sm = SimulateModel(m, k, data, &ysim);  // checks the columns
  a.diverged = sm.diverged;
  const std::size_t d0 = static_cast<std::size_t>(m.warmup_samples());
  const std::size_t n = data.rows();
  a.samples = n - d0;
  if (static_cast<std::size_t>(max_lag) >= a.samples) {
    throw InputError(data.path, 0,
                     fmt::format("--max-lag {} needs more than {} scored samples (the file has {})",
                                 max_lag, max_lag, a.samples));
  }
  a.band = kBand99 / std::sqrt(static_cast<double>(a.samples));
  const std::vector<double>& y = data.Column(m.spec.output);

  // One step ahead: every sample evaluated on measured past outputs.
  const mrd::Model model = ToRuntimeModel(m, k);
  std::vector<const std::vector<double>*> cols(model.num_channels);
  for (std::size_t c = 0; c < model.num_channels; ++c) {
    cols[c] = &data.Column(model.channel_names[c].data());
  }
  mrd::ModelRunner runner(model);
  std::array<double, kMaxChannels> row{};
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < model.num_channels; ++c) row[c] = (*cols[c])[i];
    const std::span<const double> raw(row.data(), model.num_channels);
    if (i < d0) {
      runner.Seed(raw);
      continue;
    }
    runner.Begin(raw);
    const double yh = runner.Evaluate();
    runner.Finish(y[i]);
    a.one_step.push_back(y[i] - yh);
    a.free_run.push_back(y[i] - ysim[i]);
  }
  a.rms_free_run = Rms(a.free_run);
  a.rms_one_step = Rms(a.one_step);

  a.correlations.push_back(AutoCorrelation(a.free_run, max_lag, a.band));
  a.correlations.back().name = "free-run residual: autocorrelation";
  a.correlations.push_back(AutoCorrelation(a.one_step, max_lag, a.band));
  a.correlations.back().name = "one-step residual: autocorrelation";
  for (std::size_t c = 1; c < m.channels.size(); ++c) {
    const std::string& name = m.channels[c].name;
    if (!data.Has(name)) continue;
    a.inputs.push_back(name);
    const std::vector<double>& col = data.Column(name);
    const std::vector<double> u(col.begin() + static_cast<std::ptrdiff_t>(d0), col.end());
    a.correlations.push_back(CrossCorrelation(u, a.free_run, max_lag, a.band));
    a.correlations.back().name = fmt::format("free-run residual: cross-correlation with {}", name);
    a.correlations.push_back(CrossCorrelation(u, a.one_step, max_lag, a.band));
    a.correlations.back().name = fmt::format("one-step residual: cross-correlation with {}", name);
  }
  return a;
}

std::vector<std::string> ResidualAdvice(const ResidualAnalysis& a) {
  std::vector<std::string> advice;
  // Lags within 1..kShortLag (positive: the input leads the residual) whose |r| exceeds
  // kAdviceBand times the band: a white residual leaves the 99 % band at one of five lags now
  // and then by chance, but not that far.
  const auto short_lags = [&a](const Correlation& c, bool positive) {
    std::vector<int> out;
    for (std::size_t i = 0; i < c.lags.size(); ++i) {
      const int lag = c.lags[i];
      const bool near =
          positive ? (lag >= 1 && lag <= kShortLag) : (lag <= -1 && lag >= -kShortLag);
      if (near && std::fabs(c.r[i]) > kAdviceBand * a.band) out.push_back(lag);
    }
    return out;
  };
  if (a.diverged) {
    advice.push_back(
        "the free run diverged: its correlations say little; require a stable pick ([stress] "
        "in the spec) or simulate a shorter run");
  }
  if (a.correlations.size() >= 2) {
    const std::vector<int> ar = short_lags(a.correlations[1], true);
    if (!ar.empty()) {
      advice.push_back(fmt::format(
          "the one-step residual is correlated with itself at lags {}: autoregressive "
          "dynamics are missing; offer more delays (delays = [1, 2, ...]) or powers on the "
          "[[regressor]] of the output signal",
          FormatLags(ar)));
    }
  }
  for (std::size_t i = 0; i < a.inputs.size(); ++i) {
    const std::size_t one_step = 2 + 2 * i + 1;
    if (one_step >= a.correlations.size()) break;
    const std::vector<int> lead = short_lags(a.correlations[one_step], true);
    if (!lead.empty()) {
      advice.push_back(fmt::format(
          "the one-step residual still follows {} at lags {}: input dynamics or delays are "
          "missing; offer more delays of {} (delays = [0, 1, 2, ...]) or a filtered regressor "
          "of it (transform = \"low_pass\", tau in samples)",
          a.inputs[i], FormatLags(lead), a.inputs[i]));
    }
    const std::vector<int> lag = short_lags(a.correlations[one_step], false);
    if (!lag.empty()) {
      advice.push_back(fmt::format(
          "{} follows the residual at lags {}: the data look closed-loop (a controller fed "
          "back the force); identify on an open-loop run where you can",
          a.inputs[i], FormatLags(lag)));
    }
  }
  if (advice.empty()) {
    advice.push_back(fmt::format(
        "no one-step correlation beyond {:g} times the band at lags 1...{}: nothing suggests "
        "missing dynamics",
        kAdviceBand, kShortLag));
  }
  return advice;
}

std::string ResidualSummary(const ResidualAnalysis& a, const std::string& output_unit) {
  fmt::memory_buffer b;
  auto out = std::back_inserter(b);
  const std::string u = output_unit.empty() ? "" : " " + output_unit;
  fmt::format_to(out,
                 "residuals: N {} scored samples, lags up to {}, 99 % band +-2.58/sqrt(N) = "
                 "+-{:.4g}{}\n",
                 a.samples, a.max_lag, a.band, a.diverged ? " (free run DIVERGED)" : "");
  fmt::format_to(out, "  RMS free-run residual {:.4g}{}, one-step residual {:.4g}{}\n",
                 a.rms_free_run, u, a.rms_one_step, u);
  for (const Correlation& c : a.correlations) {
    double peak = 0.0;
    int peak_lag = 0;
    const bool autocorr = c.lags.front() == 0;
    for (std::size_t i = 0; i < c.lags.size(); ++i) {
      if (autocorr && c.lags[i] == 0) continue;
      if (std::fabs(c.r[i]) > std::fabs(peak)) {
        peak = c.r[i];
        peak_lag = c.lags[i];
      }
    }
    fmt::format_to(out, "  {}: max |r| {:.3f} at lag {}; {} of {} lags outside: {}\n", c.name,
                   std::fabs(peak), peak_lag, c.outside.size(),
                   autocorr ? c.lags.size() - 1 : c.lags.size(), FormatLags(c.outside));
  }
  for (const std::string& line : ResidualAdvice(a)) fmt::format_to(out, "  suggests: {}\n", line);
  return fmt::to_string(b);
}

nlohmann::json ResidualJson(const ResidualAnalysis& a) {
  nlohmann::json corr = nlohmann::json::array();
  for (const Correlation& c : a.correlations) {
    nlohmann::json r = nlohmann::json::array();
    for (const double v : c.r) r.push_back(std::isfinite(v) ? nlohmann::json(v) : nlohmann::json());
    corr.push_back({{"name", c.name}, {"lags", c.lags}, {"r", r}, {"outside", c.outside}});
  }
  return {
      {"samples", a.samples},   {"max_lag", a.max_lag},           {"band", a.band},
      {"inputs", a.inputs},     {"rms_free_run", a.rms_free_run}, {"rms_one_step", a.rms_one_step},
      {"diverged", a.diverged}, {"correlations", corr},           {"advice", ResidualAdvice(a)}};
}

PlotFigure ResidualPlot(const ResidualAnalysis& a, const std::string& title) {
  PlotFigure f;
  f.title = title;
  f.columns = 2;
  f.rows = static_cast<int>(a.correlations.size() / 2);
  f.width = 1400;
  f.height = 330 * f.rows + 80;
  for (const Correlation& c : a.correlations) {
    PlotSpec p;
    p.title = fmt::format("{} ({} lags outside)", c.name, c.outside.size());
    p.xlabel = "lag [samples]";
    p.ylabel = "r";
    std::vector<double> lags(c.lags.begin(), c.lags.end());
    PlotSeries s;
    s.title = "r";
    s.x = lags;
    s.y = c.r;
    s.style = "impulses linewidth 2 linecolor rgb '#1f77b4'";
    p.series.push_back(std::move(s));
    const std::vector<double> bx = {lags.front(), lags.back()};
    for (const double sign : {1.0, -1.0}) {
      PlotSeries bnd;
      bnd.title = sign > 0 ? fmt::format("99 % band +-{:.3g}", a.band) : "";
      bnd.x = bx;
      bnd.y = {sign * a.band, sign * a.band};
      bnd.style = "lines dashtype 2 linewidth 1.5 linecolor rgb '#d62728'";
      p.series.push_back(std::move(bnd));
    }
    f.panels.push_back(std::move(p));
  }
  return f;
}

}  // namespace mrd::host
