#pragma once
// The SEM engine on the paper spec and 4 s of the identification profile, every candidate
// prepared: the fixture of the tests that drive the search's steps directly.
#include <string>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/sem.hpp"
#include "sem/engine/engine.hpp"
#include "sem_test_util.hpp"

namespace mrd::host::internal {

struct PaperEngineFixture {
  SemSpec spec = LoadSemSpec(std::string(MRD_SOURCE_DIR) + "/host/specs/paper.toml");
  std::vector<DataSet> data{test::DamperData("identification", 4001)};
  std::vector<ChannelInfo> ch = ComputeScales(spec, data);
  Engine eng{spec, data, ch, 2};
  PaperEngineFixture() {
    for (const SemTerm& t : GenerateCandidates(spec)) eng.AddCandidate(t);
    eng.PrepareCandidates();
  }
};

}  // namespace mrd::host::internal
