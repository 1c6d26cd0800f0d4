#pragma once
// `mrd-hil run ... --json` from a test: exit status, the JSON summary (an empty object when
// the output is no JSON) and stderr; and force-v1 on the paper run's table and excitation (the
// fixture hil_paper makes them). The including target defines MRD_BIN_DIR, MRD_SOURCE_DIR and
// MRD_PAPER_DIR.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support/process.hpp"

namespace mrd::test {

struct HilResult {
  int status = -1;
  nlohmann::json j;
  std::string err;
};

inline HilResult Hil(std::vector<std::string> args) {
  args.insert(args.begin(), {std::string(MRD_BIN_DIR) + "/mrd-hil", "run"});
  args.push_back("--json");
  ChildProcess p(args);
  HilResult r;
  r.status = p.Wait(180.0);
  r.err = p.Stderr();
  r.j = nlohmann::json::parse(p.Stdout(), nullptr, false);
  if (r.j.is_discarded()) r.j = nlohmann::json::object();
  return r;
}

// hil/scenarios/force-v1.toml with --table and --excitation of the paper run.
inline std::vector<std::string> ForceV1() {
  const std::string paper = MRD_PAPER_DIR;
  return {std::string(MRD_SOURCE_DIR) + "/hil/scenarios/force-v1.toml", "--table",
          paper + "/table.bin", "--excitation", paper + "/v1.csv"};
}

}  // namespace mrd::test
