// The run's checks: [excitation], [control], [pass], the fault schedule (scenario_reader.hpp).
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "mrd/common/file_path.hpp"
#include "mrd/sim/reference_profiles.hpp"
#include "replay_scenario.hpp"
#include "scenario_reader.hpp"

namespace mrd::hil::scenario_reader {

// [excitation] kind and what each kind needs.
bool ScenarioReader::CheckExcitation() {
  Ctx& c = c_;
  const std::string& path = path_;
  if (excitation_ == "periodic") {
    s.excitation = ExcitationKind::kPeriodic;
  } else if (excitation_ == "profile") {
    s.excitation = ExcitationKind::kProfile;
    const auto& names = ReferenceProfileNames();
    if (s.profile.empty())
      return c.Fail(at("excitation.kind"), "kind = \"profile\" needs 'profile'");
    if (std::find(names.begin(), names.end(), s.profile) == names.end()) {
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      return c.Fail(at("excitation.profile"), "unknown profile '" + s.profile + "' (" + list + ")");
    }
  } else if (excitation_ == "csv") {
    s.excitation = ExcitationKind::kCsv;
    if (s.csv_file.empty()) {
      return c.Fail(*root_.at_path("excitation.kind").node(), "kind = \"csv\" needs 'file'");
    }
    s.csv_file = ResolveBeside(path, s.csv_file);
  } else if (excitation_ == "replay") {
    if (!CheckReplay(path, root_, &s, error_)) return false;  // replay_scenario.cpp
  } else {
    return c.Fail(*root_.at_path("excitation.kind").node(),
                  "excitation kind must be \"periodic\", \"csv\", \"profile\" or \"replay\"");
  }
  if (excitation_ != "profile" && (has("excitation.profile") || has("excitation.seed"))) {
    return c.Fail(at(has("excitation.profile") ? "excitation.profile" : "excitation.seed"),
                  "'profile' and 'seed' need [excitation] kind = \"profile\"");
  }
  return true;
}

// [control] law and what each law needs (clipped-optimal: its gains file).
bool ScenarioReader::CheckControl() {
  Ctx& c = c_;
  const toml::table& root = root_;
  const bool chassis_law = IsChassisLaw(s.law);
  if (s.law != "force" && s.law != "passive-off" && s.law != "passive-on" && s.law != "constant" &&
      s.law != "skyhook" && s.law != "open-loop" && !chassis_law && s.law != "clipped-optimal") {
    return c.Fail(*root.at_path("control.law").node(),
                  "law must be force | passive-off | passive-on | constant | skyhook | "
                  "open-loop | groundhook | groundhook-on-off | hybrid | add | sh-add | "
                  "clipped-optimal");
  }
  if (s.law == "clipped-optimal") {
    if (!CheckClippedGains()) return false;
  } else if (has("control.gains") || has("control.clipped_command")) {
    return c.Fail(at(has("control.gains") ? "control.gains" : "control.clipped_command"),
                  "'gains' and 'clipped_command' need law = \"clipped-optimal\"");
  }
  if (s.clipped_command != "clipped" && s.clipped_command != "inverse") {
    return c.Fail(at("control.clipped_command"),
                  "clipped_command must be \"clipped\" or \"inverse\"");
  }
  if (chassis_law && !s.quarter_car) {
    return c.Fail(*root.at_path("control.law").node(),
                  "law \"" + s.law +
                      "\" needs [plant] model = \"quarter-car\" (the body "
                      "acceleration and wheel velocity it reads)");
  }
  if (s.law == "open-loop" && s.excitation != ExcitationKind::kReplay) {
    return c.Fail(*root.at_path("control.law").node(),
                  "law \"open-loop\" needs [excitation] kind = \"replay\" (the measured E)");
  }
  if (s.law == "constant" && s.constant_voltage > s.e_max) {
    return c.Fail(*root.at_path("control.constant_voltage").node(), "constant_voltage above e_max");
  }
  return true;
}

// law = "clipped-optimal": a structure, and its gains file (made absolute).
bool ScenarioReader::CheckClippedGains() {
  Ctx& c = c_;
  const toml::table& root = root_;
  if (!s.structure) {
    return c.Fail(*root.at_path("control.law").node(),
                  "law \"clipped-optimal\" needs [plant] model = \"structure\" (the floor "
                  "accelerations it reads)");
  }
  if (s.clipped_gains.empty()) {
    return c.Fail(*root.at_path("control.law").node(),
                  "law \"clipped-optimal\" needs [control] gains (the file mrd-structure "
                  "design --out writes)");
  }
  s.clipped_gains = ResolveBeside(path_, s.clipped_gains);
  struct stat st {};
  if (stat(s.clipped_gains.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
    return c.Fail(at("control.gains"),
                  "[control] gains '" + s.clipped_gains + "': not a readable file");
  }
  // Absolute: the firmware reads it relative to its generated config elsewhere.
  if (char* abs = realpath(s.clipped_gains.c_str(), nullptr)) {
    s.clipped_gains = abs;
    std::free(abs);
  }
  return true;
}

// [pass] limits into s (those given), and the ones the excitation or law rules out.
bool ScenarioReader::CheckPass() {
  Ctx& c = c_;
  const toml::table& root = root_;
  s.max_invariant_violations = static_cast<std::uint64_t>(pass_max_viol_);
  if (err_reach_ >= 0.0) s.max_error_reachable = err_reach_;
  if (err_all_ >= 0.0) s.max_error_all = err_all_;
  if (replay_fit_ > -HUGE_VAL) {
    if (s.excitation != ExcitationKind::kReplay) {
      return c.Fail(*root.at_path("pass.min_replay_fit").node(),
                    "min_replay_fit needs [excitation] kind = \"replay\"");
    }
    s.min_replay_fit = replay_fit_;
  }
  if (s.law == "open-loop" && (s.max_error_reachable || s.max_error_all)) {
    return c.Fail(root.contains("pass") ? *root.get("pass") : static_cast<const toml::node&>(root),
                  "law \"open-loop\" tracks no force: score it with min_replay_fit, not "
                  "max_error_*");
  }
  if (max_missed_ >= 0.0) s.max_missed_grants = static_cast<std::uint64_t>(max_missed_);
  if (expect_exit_ >= 0) s.expect_firmware_exit = expect_exit_;
  return true;
}

// Each fault within the run and with the lines it needs.
bool ScenarioReader::CheckFaults() {
  const std::string& path = path_;
  for (const Fault& f : s.faults) {
    if (f.kind != FaultKind::kCorruptTable && f.at_s >= s.duration_s) {
      *error_ = path + ":" + std::to_string(f.line) + ": fault at_s " + std::to_string(f.at_s) +
                " is not before the end (duration_s " + std::to_string(s.duration_s) + ")";
      return false;
    }
  }
  return true;
}

}  // namespace mrd::hil::scenario_reader
