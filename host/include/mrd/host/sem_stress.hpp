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
// A model passes when its free run (reference per-sample evaluation, seeded with the measured
// output like SimulateCost) stays finite and |y| <= force_bound * max |y of the data| on every
// stress record. The search rejects candidates that fail (host/src/sem/identify.cpp); selection
// skips iterations that fail (SelectIteration).

#include <span>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/sem.hpp"

namespace mrd::host {

// The stress records of spec.stress for the identification data; empty when the spec has no
// [stress]. Columns: the spec's signals (output kept as measured: it only seeds the run).
std::vector<DataSet> BuildStressData(const SemSpec& spec, std::span<const DataSet> identification);

// Verdict of one model (terms, normalised coefficients) on the stress records. Unchecked
// (checked == false, pass) when stress is empty.
StressVerdict CheckStress(const SemSpec& spec, const std::vector<ChannelInfo>& channels,
                          const std::vector<SemTerm>& terms,
                          const std::vector<double>& coefficients, std::span<const DataSet> stress);

// Records in channels (spec.Signals() order) the operating envelope: min and max of each
// signal over the identification data [raw units].
void RecordEnvelope(std::span<const DataSet> identification, std::vector<ChannelInfo>* channels);

}  // namespace mrd::host
