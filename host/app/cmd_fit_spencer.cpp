// mrd fit-spencer: the Spencer 1997 damper model fitted to measured runs (spencer_fit.hpp);
// writes a parameter file for `mrd generate --params` and the harness's `[plant] params`.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "mrd/common/cli_checks.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/spencer_fit.hpp"
#include "mrd/params/spencer_params_file.hpp"

namespace mrd::host::cli {
namespace {

struct FitOptions {
  std::vector<std::string> data, validate;
  std::string out;
  double from = -HUGE_VAL, to = HUGE_VAL;  // [s] rows with from <= t < to (as mrd slice)
  SpencerFitOptions fit;
};

FitRun LoadRun(const std::string& path, double from, double to) {
  static const std::vector<std::string> kNeed = {"x", "v", "E", "f"};
  const DataSet ds = ReadCsv(path, kNeed);
  const std::vector<double>& t = ds.Column("t");
  const double eps = 0.5 * ds.dt;
  std::size_t first = 0;
  while (first < t.size() && t[first] < from - eps) ++first;
  std::size_t last = first;
  while (last < t.size() && t[last] < to - eps) ++last;
  if (last - first < 2) {
    throw InputError(path, 0,
                     fmt::format("--from/--to keep fewer than 2 rows (file spans {} ... {} s)",
                                 t.front(), t.back()));
  }
  const auto cut = [&](const std::string& c) {
    const auto& col = ds.Column(c);
    return std::vector<double>(col.begin() + static_cast<std::ptrdiff_t>(first),
                               col.begin() + static_cast<std::ptrdiff_t>(last));
  };
  FitRun r;
  r.name = path;
  r.dt = ds.dt;
  r.x = cut("x");
  r.v = cut("v");
  r.E = cut("E");
  r.f = cut("f");
  return r;
}

// A run whose force is constant has no fit % (as mrd identify: nothing to identify).
void CheckForceVaries(const FitRun& r, const char* nothing_to) {
  const auto [lo, hi] = std::minmax_element(r.f.begin(), r.f.end());
  if (*lo < *hi) return;
  throw InputError(
      r.name, 0,
      fmt::format("output 'f' is constant ({}) in the rows used: nothing to {}", *lo, nothing_to));
}

std::string Figures(const SpencerParams& p, const FitRun& r, const SpencerFitOptions& o) {
  const FitScore s = ScoreRun(p, r, o.substeps, o.e_max);
  if (!s.finite) return "diverges";
  return fmt::format("fit {:5.1f} %, RMSE {:6.1f} N", s.fit_percent, s.rmse_n);
}

void RunFit(FitOptions o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!(o.from < o.to)) {
    throw InputError("", 0, fmt::format("--from ({}) must be less than --to ({})", o.from, o.to));
  }
  CheckOutputPath(o.out);
  std::vector<FitRun> runs, held;
  for (const std::string& p : o.data) {
    runs.push_back(LoadRun(p, o.from, o.to));
    CheckForceVaries(runs.back(), "fit");
  }
  for (const std::string& p : o.validate) {
    held.push_back(LoadRun(p, -HUGE_VAL, HUGE_VAL));
    CheckForceVaries(held.back(), "score");
  }
  std::size_t rows = 0;
  for (const FitRun& r : runs) rows += r.x.size();
  fmt::print(
      "fit-spencer: {} run(s), {} rows, {} RK4 sub-steps per sample, E clamped to "
      "[0, {:g}] V\n",
      runs.size(), rows, o.fit.substeps, o.fit.e_max);
  o.fit.progress = [](const std::string& line) {  // progress on stderr, the result on stdout
    fmt::print(stderr, "{}\n", line);
    std::fflush(stderr);
  };
  const SpencerFitResult res = FitSpencer(runs, o.fit);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const SpencerParams paper = SpencerParams::Paper(), s1997 = SpencerParams::Spencer1997();
  std::ostringstream header;
  header << "Spencer 1997 damper parameters fitted by mrd fit-spencer (Ceres, " << o.fit.substeps
         << " RK4 sub-steps per sample)\n";
  const auto report = [&](const char* what, const FitRun& r) {
    const std::string line = fmt::format("{} {}: fitted {} | spencer1997 {} | paper {}", what,
                                         r.name, Figures(res.params, r, o.fit),
                                         Figures(s1997, r, o.fit), Figures(paper, r, o.fit));
    fmt::print("{}\n", line);
    header << line << "\n";
  };
  for (const FitRun& r : runs) report("fit on", r);
  for (const FitRun& r : held) report("held out", r);
  // What the fit leaves undetermined: on stderr and in the file's header.
  for (const std::string& w : SpencerFitWarnings(res.params, runs)) {
    fmt::print(stderr, "{}\n", w);
    header << w << "\n";
  }
  std::string why;
  if (!params::CheckPhysical(res.params, &why)) throw std::runtime_error("fit result: " + why);
  WriteFileAtomic(o.out, params::SpencerParamsText(res.params, header.str()));
  fmt::print("{}: written ({:.1f} s wall)\n", o.out, wall);
}

}  // namespace

void RegisterFitSpencer(CLI::App& app) {
  auto o = std::make_shared<FitOptions>();
  CLI::App* cmd = app.add_subcommand(
      "fit-spencer",
      "Fit the Spencer 1997 damper model (14 parameters, bounded) to measured runs (CSV "
      "t,x,v,E,f as mrd import writes) by nonlinear least squares (Ceres), simulating with the "
      "harness's RK4 plant; writes a parameter file (mrd generate --params, mrd-hil [plant] "
      "params).");
  cmd->add_option("--data", o->data, "Measured run(s) to fit, FILE[,FILE...]")
      ->required()
      ->delimiter(',')
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", o->out, "Parameter file to write (TOML)")->required();
  cmd->add_option("--from", o->from, "Fit rows with t >= FROM [s] of each --data file")
      ->check(mrd::cli::Finite);
  cmd->add_option("--to", o->to, "Fit rows with t < TO [s] of each --data file")
      ->check(mrd::cli::Finite);
  cmd->add_option("--validate", o->validate,
                  "Held-out run(s), FILE[,FILE...]: scored with the fit, not fitted")
      ->delimiter(',')
      ->check(CLI::ExistingFile);
  cmd->add_option("--substeps", o->fit.substeps,
                  "RK4 steps per sample (as the scenario's [plant] substeps)")
      ->check(mrd::cli::FiniteRange(1, 1000))
      ->capture_default_str();
  cmd->add_option("--e-max", o->fit.e_max, "Measured E clamped to [0, E_MAX] [V]")
      ->check(mrd::cli::FiniteRange(0.01, 24.0))
      ->capture_default_str();
  cmd->add_option("--starts", o->fit.scatter_starts,
                  "Scattered starts besides the presets paper and spencer1997")
      ->check(mrd::cli::FiniteRange(0, 1000))
      ->capture_default_str();
  cmd->add_option("--seed", o->fit.seed, "Seed of the scattered starts")->capture_default_str();
  cmd->add_option("--search-seconds", o->fit.search_s,
                  "Starts are searched on the first SECONDS of each run (0: all rows)")
      ->check(mrd::cli::FiniteRange(0.0, 1e6))
      ->capture_default_str();
  cmd->add_option("--search-iterations", o->fit.search_iterations,
                  "Levenberg-Marquardt iterations per start in the search")
      ->check(mrd::cli::FiniteRange(1, 10000))
      ->capture_default_str();
  cmd->add_option("--polish", o->fit.polish_starts, "Best starts polished on all rows")
      ->check(mrd::cli::FiniteRange(1, 1000))
      ->capture_default_str();
  cmd->add_option("--iterations", o->fit.polish_iterations,
                  "Levenberg-Marquardt iterations of each polish")
      ->check(mrd::cli::FiniteRange(1, 10000))
      ->capture_default_str();
  cmd->add_option("--threads", o->fit.threads, "Threads (starts run in parallel)")
      ->check(mrd::cli::FiniteRange(1, 256))
      ->capture_default_str();
  cmd->callback([o] { RunFit(*o); });
}

}  // namespace mrd::host::cli
