#pragma once
// The search's invertibility check (spec [algorithm] monotone_in; the states and the verdict:
// host/include/mrd/host/invertibility.hpp, common/include/mrd/common/invertibility.hpp). The
// states are prepared once, in two segments: the envelope grid over every signal of the spec,
// then every s-th sample the identification data visited (s = ceil(scored rows /
// kGateVisitedStates)), each as the history of one runtime model that holds every regressor of
// the spec. A term's polynomial in the command (without its coefficient) is computed once per
// state and segment and kept, so a model's check is a sum over its terms per state and the
// per-state verdict of common/: the same numbers as CheckInvertibility of the exported model
// on those states. The grid comes first: a model that fails there (most do, at the box's
// corners) is refused without the visited states; and the search screens every candidate
// before any free run on the grid's corners alone (PassesScreen: every axis at an end, the
// velocity also at its two values nearest 0). Not public.

#include <array>
#include <memory>
#include <shared_mutex>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "mrd/common/invertibility.hpp"
#include "mrd/common/model.hpp"
#include "mrd/host/sem.hpp"

namespace mrd::host::internal {

class MonotoneGate {
 public:
  // Throws InputError (the spec's monotone_in line) when the spec has more regressors or
  // signals than a runtime model holds, or a signal name longer than kMaxNameLength.
  MonotoneGate(const SemSpec& spec, const std::vector<ChannelInfo>& channels,
               std::span<const DataSet> identification);

  // Verdict of terms with coefficients theta (normalised units). Thread-safe.
  MonotoneVerdict Check(const std::vector<SemTerm>& terms, const std::vector<double>& theta) const;
  // Check(...).pass, stopping at the first failing state. Thread-safe.
  bool Passes(const std::vector<SemTerm>& terms, const std::vector<double>& theta) const;
  // The same on the screen states (grid corners) alone: a model that fails it fails Passes.
  // Thread-safe.
  bool PassesScreen(const std::vector<SemTerm>& terms, const std::vector<double>& theta) const;

  std::size_t states() const { return grid_.size() + visited_.size(); }

 private:
  enum Segment : std::size_t { kScreen = 0, kGrid = 1, kVisited = 2 };
  // How a term holds E(k): a_lo ... a_hi of the command's powers can be non-zero (1 <= lo <=
  // hi <= kMaxInputDegree: an identity E(k)^p gives a_p alone, a low-pass one a_1 ... a_p).
  struct TermShape {
    std::string problem;  // non-empty: the term cannot be exported as it is (all states fail)
    bool e_term = false;  // it has an E(k) factor
    std::size_t lo = 1, hi = 0;
    Term term;  // over model_'s regressors
  };
  // A term's part in every state of one segment: (hi - lo + 1) coefficients per state.
  struct TermPart {
    TermShape shape;
    std::vector<double> a;  // state-major; empty when the term has no E(k) factor
  };
  struct State {
    std::size_t source = 0;  // index into sources_
    std::size_t row = 0;     // data row (visited states)
    int velocity_sign = 1;
    std::array<double, kMaxChannels> raw{};  // channel values (inputs at k, output at k - 1)
  };

  TermShape Shape(const SemTerm& term) const;
  std::shared_ptr<const TermPart> Part(const SemTerm& term, Segment seg) const;
  TermPart ComputePart(const SemTerm& term, Segment seg) const;
  const std::vector<State>& States(Segment seg) const {
    return seg == kScreen ? screen_ : (seg == kGrid ? grid_ : visited_);
  }
  // First failing state of the model (-1: none) over the segments (kScreen alone, or kGrid
  // then kVisited); every state's verdict counted into *v when v != nullptr (else it stops at
  // the first failure).
  long Run(const std::vector<SemTerm>& terms, const std::vector<double>& theta, bool screen,
           MonotoneVerdict* v) const;
  std::string Describe(Segment seg, std::size_t state, const StateInvertibility& s) const;

  const SemSpec& spec_;
  Model model_;  // every regressor of the spec, no terms
  std::size_t input_ = 0;
  bool input_past_ = false;  // the spec offers the command's past (delay >= 1 or a low-pass)
  InvertibilityLimits limits_;
  std::vector<std::string> sources_;  // data file paths, then "grid"
  std::vector<State> screen_, grid_, visited_;
  std::vector<RegressorHistory> screen_histories_, grid_histories_;  // one per state
  // What rebuilds the visited states' histories for a new term: no history is kept.
  std::span<const DataSet> data_;
  std::size_t stride_ = 1;

  mutable std::shared_mutex mu_;
  // By the term's factors (Part): regressor, delay and power, 16 bits each.
  mutable std::unordered_map<std::string, std::shared_ptr<const TermPart>> parts_[3];
};

}  // namespace mrd::host::internal
