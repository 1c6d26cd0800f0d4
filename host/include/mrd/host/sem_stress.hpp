#pragma once
// Stress check of the SEM search (issue 13): a model identified on one bench run must stay
// bounded on inputs its data never had. The stress input is built from the identification
// data alone (no new measurements), per data set:
//
//   A: the stretch signals multiplied by `stretch` (velocity, displacement beyond the
//      envelope), then `hold` samples with every input held at its last value;
//   B: A with each sweep signal (the command voltage) replaced by a triangle over its whole
//      data range [min, max], period `sweep_period` samples (only when sweep signals are set).
//
// and the rest records (BuildRestData, when `rest` > 0): four records of `rest` samples with
// the stretch signals at 0 (no motion), every other input at its data minimum or at its
// maximum, and the output seeded at +max or -max |y| of the data. A model whose output grows
// at rest (a pole outside the unit circle where the velocity is zero, e.g. y(k) = 1.004 y(k-1)
// at 0 V) fails them: identification data seldom rest long enough to show it, a bench run or a
// vehicle may rest for seconds.
//
// A model passes when its free run (reference per-sample evaluation, seeded with the measured
// output like SimulateCost) stays finite and |y| <= force_bound * max |y of the data| on every
// stress record. The search rejects candidates that fail A and B (their least-squares
// coefficients; host/src/sem/search/); every recorded iteration (after its output-error
// refinement) and every move of the cross-validated pick is checked on the rest records too,
// and selection skips iterations that fail (SelectIteration).

#include <span>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/sem.hpp"

namespace mrd::host {

// The stress records of spec.stress for the identification data; empty when the spec has no
// [stress]. Columns: the spec's signals (output kept as measured: it only seeds the run).
std::vector<DataSet> BuildStressData(const SemSpec& spec, std::span<const DataSet> identification);

// The four rest records of spec.stress (above); empty without [stress] or with rest = 0.
std::vector<DataSet> BuildRestData(const SemSpec& spec, std::span<const DataSet> identification);

// Verdict of one model (terms, normalised coefficients) on the stress records. Unchecked
// (checked == false, pass) when stress is empty.
StressVerdict CheckStress(const SemSpec& spec, const std::vector<ChannelInfo>& channels,
                          const std::vector<SemTerm>& terms,
                          const std::vector<double>& coefficients, std::span<const DataSet> stress);

// Records in channels (spec.Signals() order) the operating envelope: min and max of each
// signal over the identification data [raw units].
void RecordEnvelope(std::span<const DataSet> identification, std::vector<ChannelInfo>* channels);

}  // namespace mrd::host
