// mrd-hil run: the scenario loop (run.hpp), its phases in run_session.hpp (validate, bring-up,
// step, teardown). Scores and fault figures: run_scores.cpp.
#include "mrd/hil/run/run.hpp"

#include "run_session.hpp"

namespace mrd::hil {

int RunScenario(const Scenario& scenario, const RunOptions& options, RunResult* r,
                std::string* error) {
  ScenarioRun run(scenario, options, r, error);
  if (const int rc = run.Validate(); rc != 0) return rc;
  bool finished = false;  // a corrupt_table run ends in its bring-up
  if (const int rc = run.BringUp(&finished); rc != 0 || finished) return rc;
  for (std::int64_t k = 0; k < run.steps(); ++k) {
    if (const int rc = run.Step(k); rc != 0) return rc;
  }
  return run.Teardown();
}

}  // namespace mrd::hil
