#pragma once
// Invertibility of a model over its identification envelope (the per-state check:
// common/include/mrd/common/invertibility.hpp). The states:
//   - visited: every sample the data reached (from the model's largest delay on), the history
//     built from the measured values (one-step: the measured force fed back);
//   - grid: the envelope box of the channels the model reads, every channel held at a grid
//     value (velocity kGridVelocity points, none at 0; every other channel, the force fed back
//     included, kGridOther points; the command's past, when the model remembers it through a
//     delay or a low-pass, kGridInput points over the command range), the model in steady state.
// `mrd identify`, `simulate`, `compare` and `export` report it; the search can require it
// (spec [algorithm] monotone_in, docs/spec.md).

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mrd/common/invertibility.hpp"
#include "mrd/common/model.hpp"
#include "mrd/common/table.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/model_file.hpp"

namespace mrd::host {

inline constexpr int kGridVelocity = 20;
inline constexpr int kGridOther = 9;
inline constexpr int kGridInput = 5;

// Range of one signal over the identification data [raw units] (model file channel envelope).
struct SignalRange {
  std::string name;
  double min = 0.0;
  double max = 0.0;
};

struct InvertibilitySettings {
  std::string input = "E";     // the command channel
  std::string velocity = "v";  // its sign is the dissipative direction (absent: +1)
  double e_min = 0.0;          // command range checked [V]
  double e_max = 2.25;
  double tolerance = -1.0;  // [force per command unit]; < 0: DefaultSlopeTolerance
};

// Grid values over [lo, hi]: n points with both ends (one point, lo, when n <= 1 or the range
// is empty). An even n over a range symmetric about 0 never lands on 0.
std::vector<double> GridAxis(double lo, double hi, int n);

// One state in raw units, for messages.
struct InvertibilityState {
  std::string source;   // "grid" or the data file
  std::size_t row = 0;  // data row (0-based), data states only
  // Channel values of the state: inputs at sample k, the output and the command at k - 1.
  std::vector<std::pair<std::string, double>> values;
  StateInvertibility verdict;
};

struct InvertibilityReport {
  std::string input, output;
  double e_min = 0.0, e_max = 0.0, tolerance = 0.0;
  // Non-empty: the command does not enter as a polynomial of degree <= 4 at delay 0 (through
  // abs_pow, sign, tanh or clip, or a higher degree): no state can be checked, all fail.
  std::string structure_problem;
  bool reads_input = true;  // false: E(k) does not enter the model (flat: every state passes)
  std::size_t visited_states = 0, visited_failing = 0;
  std::size_t grid_states = 0, grid_failing = 0;
  std::size_t non_monotone = 0, not_one_to_one = 0;
  bool has_worst = false;
  InvertibilityState worst;  // lowest df/dE * sign(v) of all states (failing or not)

  std::size_t states() const { return visited_states + grid_states; }
  std::size_t failing() const { return visited_failing + grid_failing; }
  double share_percent() const;  // failing / states [%] (100 with a structure problem)
  bool pass() const { return structure_problem.empty() && failing() == 0; }
};

// The check. model: the runtime model (channels by name); envelope: ranges of the channels it
// reads, the output's included (one missing: no grid states); visited: data sets with the
// model's channels as columns (InputError naming the file when one is missing).
InvertibilityReport CheckInvertibility(const Model& model, const InvertibilitySettings& settings,
                                       std::span<const SignalRange> envelope,
                                       std::span<const DataSet> visited);

// The command a model file is checked in: the spec's monotone_in, else "E" when it is an input
// signal of the spec; "" when neither (nothing to check).
std::string ModelCommand(const ModelFile& m);

// CheckInvertibility of iteration k of a model file over its recorded envelope (channel
// ranges; none in model files older than the envelope: no grid states) and the visited data.
// e_range: the command range checked [V]; none: the command's envelope in the model file (the
// range the data reached). Input: ModelCommand (settings.input ignored when it is "").
InvertibilityReport CheckModelInvertibility(const ModelFile& m, int k,
                                            std::span<const DataSet> visited,
                                            std::optional<std::pair<double, double>> e_range = {});

// CheckModelInvertibility of the selected iteration on the identification data, recorded in
// m->invertibility (as `mrd identify` writes it). Returns the report.
InvertibilityReport RecordInvertibility(ModelFile* m, std::span<const DataSet> identification);

// The check `mrd export` makes: the table's model over the table's command range, on the
// envelope grid and the states of the identification data named in the model file when every
// one of them can still be read (else the grid alone).
InvertibilityReport ExportInvertibility(const ModelFile& m, const std::string& input,
                                        const CoefficientTable& table);
// Writes the report into the table's invertibility record (format version 3).
void RecordTableInvertibility(const InvertibilityReport& r, CoefficientTable* table);

// {"input", "e_min", "e_max", "tolerance", "states", "failing", "share_percent",
//  "visited_states", "grid_states", "non_monotone", "not_one_to_one", "pass",
//  "structure_problem" (when set), "worst" (in words)}.
nlohmann::json InvertibilityJson(const InvertibilityReport& r);

// One line: "invertibility in E on [0, 2.25] V: 0 of 1234 states fail (0 %; 1000 visited, 234
// on the envelope grid)", then for a failing model the counts by kind and the worst state.
std::string InvertibilitySummary(const InvertibilityReport& r);
// "v = 1.67, f(k-1) = 120, E(k-1) = 1.2 (grid): df/dE = -340 at E = 2.25".
std::string DescribeState(const InvertibilityReport& r, const InvertibilityState& s);

}  // namespace mrd::host
