// [excitation] kind = "replay" in a scenario (replay_scenario.hpp).
#include "replay_scenario.hpp"

#include "mrd/common/file_path.hpp"
#include "mrd/common/input_file.hpp"

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
