// mrd generate: reference data sets from the Spencer damper (docs/design.md §4).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>

#include "commands.hpp"
#include "mrd/common/cli_checks.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/params_file.hpp"
#include "mrd/host/profiles.hpp"

namespace mrd::host::cli {
namespace {

struct GenerateOptions {
  std::string profile;
  std::uint64_t seed = 1;
  std::string preset = "paper";
  std::string params_file;
  std::string out;
  int substeps = 100;
  double noise = 0.0;  // [N] standard deviation of the measurement noise added to f
};

// White Gaussian noise of standard deviation sigma [N] added to f: a force transducer's. Seeded
// by seed alone (mt19937_64 and Box-Muller, written out so that every standard library gives the
// same file), apart from the profile's own random parts.
void AddForceNoise(double sigma, std::uint64_t seed, std::vector<double>* f) {
  if (sigma == 0.0) return;
  std::mt19937_64 rng(seed ^ 0x6e6f697365ULL);  // "noise"
  auto uniform = [&] {                          // (0, 1]
    return (static_cast<double>(rng() >> 11) + 1.0) * 0x1.0p-53;
  };
  constexpr double kTwoPi = 6.283185307179586;
  for (double& v : *f)
    v += sigma * std::sqrt(-2.0 * std::log(uniform())) * std::cos(kTwoPi * uniform());
}

// A non-finite force: the parameters made the simulation diverge (named, with the time [s]).
void CheckForceFinite(const GenerateOptions& o, const Excitation& ex,
                      const std::vector<double>& f) {
  const auto bad = std::find_if(f.begin(), f.end(), [](double v) { return !std::isfinite(v); });
  if (bad == f.end()) return;
  const double t = ex.t[static_cast<std::size_t>(bad - f.begin())];
  const std::string source = o.params_file.empty() ? "preset " + o.preset : "";
  throw InputError(
      o.params_file, 0,
      fmt::format("{}{}the simulation diverged: non-finite force ({}) at t = {:.3f} "
                  "s (parameters out of the damper's range?)",
                  source, source.empty() ? "" : ": ", std::isnan(*bad) ? "NaN" : "inf", t));
}

void RunGenerate(const GenerateOptions& o) {
  CheckOutputPath(o.out);
  const SpencerParams params =
      o.params_file.empty() ? SpencerPreset(o.preset) : LoadSpencerParams(o.params_file);
  const Excitation ex = MakeExcitation(o.profile, o.seed);
  std::vector<double> f = SimulateReferenceDamper(params, ex, o.substeps);
  CheckForceFinite(o, ex, f);
  AddForceNoise(o.noise, o.seed, &f);
  const auto [fmin, fmax] = std::minmax_element(f.begin(), f.end());
  const auto [emin, emax] = std::minmax_element(ex.E.begin(), ex.E.end());
  const auto [vmin, vmax] = std::minmax_element(ex.v.begin(), ex.v.end());
  WriteCsv(o.out, {"t", "x", "v", "E", "f"}, {ex.t, ex.x, ex.v, ex.E, f});
  fmt::print(
      "{}: {} rows, t 0 ... {:.3f} s, v {:.2f} ... {:.2f} cm/s, E {:.2f} ... {:.2f} V, "
      "f {:.1f} ... {:.1f} N\n",
      o.out, ex.t.size(), ex.t.back(), *vmin, *vmax, *emin, *emax, *fmin, *fmax);
}

}  // namespace

void RegisterGenerate(CLI::App& app) {
  auto o = std::make_shared<GenerateOptions>();
  CLI::App* cmd =
      app.add_subcommand("generate",
                         "Simulate the Spencer reference damper on a reference profile; write CSV "
                         "t,x,v,E,f at 1 ms.");
  cmd->add_option("--profile", o->profile,
                  fmt::format("{}", fmt::join(ReferenceProfileNames(), " | ")))
      ->required()
      ->check(CLI::IsMember(ReferenceProfileNames()));
  cmd->add_option("--seed", o->seed, "Seed of the random parts (deterministic)")
      ->capture_default_str();
  auto* preset = cmd->add_option("--preset", o->preset, "Damper parameters: paper | spencer1997")
                     ->check(CLI::IsMember({"paper", "spencer1997"}))
                     ->capture_default_str();
  cmd->add_option("--params", o->params_file, "TOML file of damper parameters")
      ->check(CLI::ExistingFile)
      ->excludes(preset);
  cmd->add_option("--substeps", o->substeps, "RK4 sub-steps per 1 ms sample")
      ->check(mrd::cli::FiniteRange(1, 10000))
      ->capture_default_str();
  cmd->add_option("--noise", o->noise,
                  "Standard deviation of white Gaussian noise added to f [N] (a force "
                  "transducer's; seeded by --seed)")
      ->check(mrd::cli::FiniteRange(0.0, 1e6))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Output CSV file")->required();
  cmd->callback([o] { RunGenerate(*o); });
}

}  // namespace mrd::host::cli
