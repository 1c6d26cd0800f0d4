// mrd identify: SEM identification (docs/design.md §5) of a polynomial NARX model from data.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "mrd/common/cli_checks.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/invertibility.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem.hpp"
#include "mrd/host/sem_default.hpp"
#include "mrd/host/sem_family.hpp"

namespace mrd::host::cli {
namespace {

struct IdentifyOptions {
  std::vector<std::string> data;
  std::vector<std::string> validate;
  std::string spec;
  std::string out;
  std::optional<double> threshold;
  std::optional<int> max_iterations;
  std::optional<double> target_j;
  std::optional<std::string> strategy;
  std::optional<std::int64_t> max_candidates;
  std::vector<std::string> initial;
  int threads = 0;
};

std::vector<DataSet> ReadAll(const std::vector<std::string>& paths,
                             const std::vector<std::string>& signals) {
  std::vector<DataSet> out;
  for (const auto& p : paths) out.push_back(ReadCsv(p, signals));
  return out;
}

// Spec monotone_in: the iteration's invertibility verdict and the candidates it refused.
void PrintMonotone(const SemIteration& it) {
  if (!it.monotone.checked) return;
  fmt::print(stderr, ", monotone {} ({:.3g} % of {} states fail, {} candidates rejected)",
             it.monotone.pass ? "pass" : "FAIL", it.monotone.share_percent, it.monotone.states,
             it.monotone_rejected);
}

void RunIdentify(const IdentifyOptions& o) {
  CheckOutputPath(o.out);  // before the identification, which may take minutes
  // No --spec: each built-in spec, the best on unseen data kept (sem_default.hpp).
  const std::optional<SemSpec> given =
      o.spec.empty() ? std::nullopt : std::optional<SemSpec>(LoadSemSpec(o.spec));
  // Unknown columns are reported against the spec (Identify), so read without requirements.
  const std::vector<DataSet> data = ReadAll(o.data, {});
  const std::vector<DataSet> val = ReadAll(o.validate, {});
  SemOptions so;
  if (o.strategy) so.strategy = *o.strategy == "first" ? Strategy::kFirst : Strategy::kBest;
  so.threshold_percent = o.threshold;
  so.max_iterations = o.max_iterations;
  so.target_j = o.target_j;
  so.max_candidates = o.max_candidates;
  if (!o.initial.empty()) so.initial = o.initial;
  so.threads = o.threads > 0 ? o.threads
                             : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  // Progress on stderr (one line per iteration); the result on stdout.
  so.progress = [](const SemIteration& it) {
    fmt::print(stderr, "iteration {:3d}: {:2d} terms, J {:.6g}, validation J [{:.6g}], {:.2f} s",
               it.iteration, it.terms.size(), it.j, fmt::join(it.validation_j, ", "), it.elapsed_s);
    if (it.stress.checked) {  // spec [stress]: verdict, peak |y| / data's, candidates refused
      fmt::print(stderr, ", stress {} (peak {:.3g}, {} candidates rejected)",
                 it.stress.pass ? "pass" : "FAIL", it.stress.peak, it.stress_rejected);
    }
    PrintMonotone(it);
    fmt::print(stderr, "\n");
    std::fflush(stderr);
  };
  // A spec with transform families runs once per combination (sem_family.hpp).
  auto member = [](std::size_t i, std::size_t n, const std::vector<std::string>& regs,
                   const FamilyCombination& c) {
    fmt::print(stderr, "{}\n", FamilyProgressLine(i, n, regs, c));
  };
  // Without --spec: a line as each built-in spec starts and ends.
  auto spec_line = [](std::size_t i, std::size_t n, const SpecCandidate& c, bool done) {
    fmt::print(stderr, "{}\n", SpecProgressLine(i, n, c, done));
    std::fflush(stderr);
  };
  DefaultIdentification di;
  if (given) {
    di.identification = IdentifyFamilies(*given, data, val, so, member);
  } else {
    di = IdentifyDefault(data, val, so, member, spec_line);
  }
  const FamilyIdentification& fi = di.identification;
  const SemSpec& spec = fi.spec;
  const SemResult& r = fi.result;
  ModelFile mf = MakeModelFile(fi.spec, r);
  mf.family = fi.family;
  mf.spec_choice = di.choice;
  mf.identification_data = o.data;
  mf.validation_data = o.validate;
  const InvertibilityReport inv = RecordInvertibility(&mf, data);
  SaveModelFile(mf, o.out);
  const SemIteration& sel = mf.Iteration(mf.selected);
  fmt::print("{}: {} candidates, {} iterations, selected iteration {} ({} terms, J {:.6g}; {})\n",
             o.out, r.num_candidates, r.iterations.size() - 1, mf.selected, sel.terms.size(), sel.j,
             mf.selection_rule);
  // What the search's extras cost against the search itself (spec keys exchange and
  // one_step_start; docs/spec.md): wall time, for the user only (not in the model file).
  fmt::print("search cost: adds and prunes {:.2f} s, exchange moves {}, second start {}\n",
             r.path_s, spec.exchange ? fmt::format("{:.2f} s", r.exchange_s) : std::string("off"),
             r.second_start_s < 0.0 ? std::string("off")
                                    : fmt::format("{:.2f} s (a {}-term one-step start)",
                                                  r.second_start_s, r.second_start_terms));
  fmt::print("selected iteration {}: {}\n", mf.selected, InvertibilitySummary(inv));
  const SpecChoice& sc = mf.spec_choice;
  if (!sc.empty()) {
    fmt::print("no --spec: built-in specs by {}:\n", sc.rule);
    for (std::size_t i = 0; i < sc.specs.size(); ++i) {
      const SpecCandidate& c = sc.specs[i];
      fmt::print("  {}: RMSE {:.6g} {}, {} terms{}\n", c.name, c.rmse, r.channels[0].name, c.terms,
                 static_cast<int>(i) == sc.chosen ? "  <- chosen" : "");
    }
  }
  const FamilyResult& f = mf.family;
  if (!f.empty()) {
    fmt::print("transform family ({}):\n", f.rule);
    for (std::size_t c = 0; c < f.combinations.size(); ++c) {
      const FamilyCombination& fc = f.combinations[c];
      fmt::print("  {}: score {:.6g}, {} terms{}\n", FamilyMembers(f.regressors, fc), fc.score,
                 fc.terms, static_cast<int>(c) == f.chosen ? "  <- chosen" : "");
    }
  }
}

}  // namespace

void RegisterIdentify(CLI::App& app) {
  auto o = std::make_shared<IdentifyOptions>();
  CLI::App* cmd = app.add_subcommand(
      "identify", "SEM identification: structure by simulation error, parameters by LS.");
  cmd->add_option("--data", o->data, "Identification data file(s), comma separated")
      ->required()
      ->delimiter(',');
  cmd->add_option("--spec", o->spec,
                  "Candidate spec (TOML), e.g. host/specs/paper.toml; default: the built-in "
                  "copies of host/specs/paper-saturating.toml and host/specs/nees.toml, each "
                  "identified, the one with the lowest cross-validated (or validation) RMSE kept");
  cmd->add_option("--validate", o->validate, "Validation data file(s), comma separated")
      ->delimiter(',');
  cmd->add_option("--out", o->out, "Model file to write (JSON)")->required();
  cmd->add_option("--threshold", o->threshold,
                  "Least decrease of J to accept a candidate [%] (first improvement)")
      ->check(mrd::cli::FiniteRange(0.0, 99.999));
  cmd->add_option("--max-iterations", o->max_iterations, "Most major iterations")
      ->check(mrd::cli::FiniteRange(0, 100000));
  cmd->add_option("--target-j", o->target_j, "Stop once J is at or below this (finite)")
      ->check(mrd::cli::Finite);
  cmd->add_option("--max-candidates", o->max_candidates,
                  "Most candidate factor combinations (default: the spec's [limits] "
                  "max_candidates, else 200000)")
      ->check(mrd::cli::FiniteRange(std::int64_t{1}, std::int64_t{2000000000}));
  cmd->add_option("--threads", o->threads, "Worker threads (0: all cores)")
      ->check(mrd::cli::FiniteRange(0, 256))
      ->capture_default_str();
  cmd->add_option("--initial", o->initial,
                  "Initial structure: terms like y(k-1)^2*u1(k), comma separated")
      ->delimiter(',');
  cmd->add_option("--strategy", o->strategy,
                  "first (built-in default) | best improvement; default: the spec's strategy")
      ->check(CLI::IsMember({"best", "first"}));
  cmd->callback([o] { RunIdentify(*o); });
}

}  // namespace mrd::host::cli
