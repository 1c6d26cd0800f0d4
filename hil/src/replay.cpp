#include "mrd/hil/replay.hpp"

#include <cmath>
#include <fstream>

#include "mrd/common/file_path.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/hil/run.hpp"
#include "replay_scenario.hpp"

namespace mrd::hil {

bool LoadReplay(const std::string& path, bool open_loop, const std::string& demand_column,
                Trace* trace, ReplayRun* run, std::string* error) {
  // The header first, so that a missing column is named before any row is read.
  std::string text;
  if (!ReadInputFile(path, std::uint64_t{256} << 20, &text, error)) return false;
  const std::string header = text.substr(0, text.find('\n'));
  std::vector<std::string> names;
  for (std::size_t a = 0; a <= header.size();) {
    std::size_t b = header.find(',', a);
    if (b == std::string::npos) b = header.size();
    std::string n = header.substr(a, b - a);
    while (!n.empty() && (n.back() == '\r' || n.back() == ' ')) n.pop_back();
    while (!n.empty() && n.front() == ' ') n.erase(n.begin());
    names.push_back(n);
    a = b + 1;
  }
  std::string missing;
  for (const std::string& need :
       {std::string("x"), std::string("v"), std::string("E"), demand_column}) {
    bool found = false;
    for (const std::string& n : names) found = found || n == need;
    if (!found && missing.find("'" + need + "'") == std::string::npos) {
      missing += (missing.empty() ? "'" : ", '") + need + "'";
    }
  }
  if (!missing.empty()) {
    *error = Printable(path) + ":1: a replay file needs columns x, v, E and " +
             Printable(demand_column) + " (measured motion, command and force); missing " +
             Printable(missing);
    return false;
  }
  Trace with_f, with_e;
  if (!LoadTrace(path, demand_column, &with_f, error)) return false;
  if (!LoadTrace(path, "E", &with_e, error)) return false;
  run->f = with_f.demand;
  if (open_loop) {
    // Step k (row k -> k + 1) is driven with E of row k + 1, as `mrd generate` and `mrd
    // fit-spencer` hold it; the last row holds. [V] -> [mV], the open-loop law's unit.
    std::vector<double>& e = with_e.demand;
    for (std::size_t k = 0; k < e.size(); ++k) e[k] = 1e3 * e[std::min(k + 1, e.size() - 1)];
    with_f.demand = std::move(e);
  }
  *trace = std::move(with_f);
  return true;
}

ReplayScores ScoreReplay(const std::vector<StepRecord>& trace, const ReplayRun& run) {
  ReplayScores s;
  const std::size_t n = std::min(trace.size(), run.f.size() > 0 ? run.f.size() - 1 : 0);
  if (n == 0) return s;
  double mean = 0.0;
  for (std::size_t k = 0; k < n; ++k) mean += run.f[k + 1];
  mean /= static_cast<double>(n);
  double e2 = 0.0, d2 = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double e = run.f[k + 1] - trace[k].force;
    e2 += e * e;
    d2 += (run.f[k + 1] - mean) * (run.f[k + 1] - mean);
  }
  s.samples = n;
  s.rmse_n = std::sqrt(e2 / static_cast<double>(n));
  s.fit_percent = d2 > 0.0 ? 100.0 * (1.0 - std::sqrt(e2 / d2)) : 0.0;
  return s;
}

}  // namespace mrd::hil

namespace mrd::hil {

bool CheckReplay(const std::string& path, const toml::table& root, Scenario* s,
                 std::string* error) {
  s->excitation = ExcitationKind::kReplay;
  if (s->csv_file.empty()) {
    const toml::node* n = root.at_path("excitation.kind").node();
    *error = Printable(path) + ":" + std::to_string(n != nullptr ? n->source().begin.line : 0) +
             ": kind = \"replay\" needs 'file' (a measured run with columns x, v, E, f)";
    return false;
  }
  s->csv_file = ResolveBeside(path, s->csv_file);
  return true;
}

}  // namespace mrd::hil
