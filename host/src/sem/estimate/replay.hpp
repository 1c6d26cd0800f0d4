#pragma once
// A data set prepared once for many reference free runs (SimulateCost's per-sample evaluation):
// the validation runs and stress checks of every iteration and candidate
// (host/src/sem/identify.cpp, host/src/sem/stress/stress.cpp) run on the same records, so the
// normalised output, the row weights and the transformed inputs to each offered power are computed
// once instead of per run. Run gives SimulateCost's result bit for bit (same operations in the same
// order). Not public.

#include <limits>
#include <string>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/sem.hpp"

namespace mrd::host::internal {

class Replay {
 public:
  Replay(const SemSpec& spec, const std::vector<ChannelInfo>& channels, const DataSet& data);

  // SimulateCost(spec, channels, terms, coefficients, data, ysim) of the data set given at
  // construction. Thread-safe (reads only). stop_above (finite): the run stops at the first
  // sample whose |output| exceeds it or is not finite and returns +inf (ysim then ends there,
  // zeros after); +inf: never stops early.
  double Run(const std::vector<SemTerm>& terms, const std::vector<double>& coefficients,
             std::vector<double>* ysim = nullptr,
             double stop_above = std::numeric_limits<double>::infinity()) const;

  const std::string& path() const { return path_; }

 private:
  const SemSpec& spec_;
  std::string path_;
  std::size_t n_ = 0, d0_ = 0;
  std::vector<double> y_, w_;                // normalised output, cost weight per row
  std::vector<std::vector<double>> input_;   // [regressor]: transformed (empty: output)
  std::vector<std::vector<int>> pow_index_;  // [regressor][power] -> pow_ (-1: none)
  std::vector<std::vector<double>> pow_;     // input_[r]^p per row (Pow's product)
};

// CheckStress (sem_stress.hpp) on stress records prepared as Replay.
StressVerdict CheckStressPrepared(const SemSpec& spec, const std::vector<SemTerm>& terms,
                                  const std::vector<double>& coefficients,
                                  const std::vector<Replay>& stress);
// CheckStressPrepared(...).pass, each run stopped at its first sample out of the bound.
bool StressPassesPrepared(const SemSpec& spec, const std::vector<SemTerm>& terms,
                          const std::vector<double>& coefficients,
                          const std::vector<Replay>& stress);

}  // namespace mrd::host::internal
