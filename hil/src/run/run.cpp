// mrd-hil run: the scenario loop (run.hpp), its phases in run_session.hpp (validate, bring-up,
// step, teardown). Scores and fault figures: run_scores.cpp.
#include "mrd/hil/run/run.hpp"

#include "corners_run.hpp"
#include "mrd/common/lockstep_sched.hpp"
#include "run_session.hpp"

namespace mrd::hil {

int RunScenario(const Scenario& scenario, const RunOptions& options, RunResult* r,
                std::string* error) {
  // A full car with [channels]: four corners of one firmware over CAN or Modbus (corners_run.hpp).
  if (scenario.full_car && scenario.channels.any()) {
    return RunCorners(scenario, options, r, error);
  }
  ScenarioRun run(scenario, options, r, error);
  if (const int rc = run.Validate(); rc != 0) return rc;
  // Lockstep: this thread and the firmware's loop hand each period back and forth
  // (lockstep_sched.hpp); the firmware sets its loop thread the same way.
  const common::ScopedLockstepScheduling sched(run.lockstep());
  bool finished = false;  // a corrupt_table run ends in its bring-up
  if (const int rc = run.BringUp(&finished); rc != 0 || finished) return rc;
  for (std::int64_t k = 0; k < run.steps(); ++k) {
    if (const int rc = run.Step(k); rc != 0) return rc;
  }
  return run.Teardown();
}

}  // namespace mrd::hil
