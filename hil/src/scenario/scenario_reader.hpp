#pragma once
// LoadScenario's reader (scenario.cpp): the scenario, the keys that are not fields of it (read
// first, checked and converted after), one method per section and per check. Its methods live
// by what they read:
//   scenario_keys.cpp          each [section]'s keys and their ranges (setters below)
//   scenario_reader.cpp        Read, the file's top level and [[fault]] tables
//   scenario_checks_plant.cpp  [plant] files, structure, NARX model, quarter car and road
//   scenario_checks_run.cpp    [excitation], [control], [pass] and the fault schedule
// Error messages: "FILE:LINE: reason" (the node's line; an override names its --set). Start-up
// only (allocates; toml++ exceptions are caught by LoadScenario).

#include <toml++/toml.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "mrd/common/input_file.hpp"
#include "mrd/hil/plants/structure_plant.hpp"
#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil::scenario_reader {

struct Ctx {
  const std::string& path;
  std::string* error;
  bool Fail(const toml::node& n, const std::string& why) {  // why may echo input
    const auto& from = n.source().path;  // "--set KEY=VALUE" for an override's node
    *error = from && *from != path ? *from + ": " + Printable(why)
                                   : Printable(path) + ":" + std::to_string(n.source().begin.line) +
                                         ": " + Printable(why);
    return false;
  }
};

using Setter = std::function<bool(const toml::node&, Ctx&)>;

// A key's value into *out when it is within range (else c.Fail naming the key).
Setter Num(double* out, double lo, double hi, const char* key);
template <typename T>
Setter Int(T* out, std::int64_t lo, std::int64_t hi, const char* key) {
  return [=](const toml::node& n, Ctx& c) {
    const auto v = n.value_exact<std::int64_t>();
    if (!v || *v < lo || *v > hi) {
      return c.Fail(n, std::string("'") + key + "' must be an integer in [" + std::to_string(lo) +
                           ", " + std::to_string(hi) + "]");
    }
    *out = static_cast<T>(*v);
    return true;
  };
}
Setter Str(std::string* out, const char* key);
Setter Flag(bool* out, const char* key);
// A list of names, each one of `allowed` (name -> flag it sets).
Setter Names(const std::map<std::string, bool*>& allowed, const char* key);
// Every key of t through its setter; an unknown key fails ("unknown key 'K'" + where).
bool ApplyTable(const toml::table& t, const std::map<std::string, Setter>& keys,
                const std::string& where, Ctx& c);

// LoadScenario's state while it reads one file.
class ScenarioReader {
 public:
  ScenarioReader(const std::string& path, toml::table* root, std::string* error)
      : path_(path), root_(*root), error_(error), c_{path, error} {
    s.path = path;
    hb_ms_ = s.heartbeat_timeout_s * 1e3;
  }
  ScenarioReader(const ScenarioReader&) = delete;
  ScenarioReader& operator=(const ScenarioReader&) = delete;

  // Every key of the file into s (or the reader's own fields), then the checks in order.
  bool Read();
  Scenario s;

 private:
  std::map<std::string, Setter> PlantKeys();
  std::map<std::string, Setter> StructureKeys();
  std::map<std::string, Setter> QuarterCarKeys();
  std::map<std::string, Setter> FullCarKeys();
  std::map<std::string, Setter> ChannelsKeys();
  std::map<std::string, Setter> RoadKeys();
  std::map<std::string, Setter> ExcitationKeys();
  std::map<std::string, Setter> ControlKeys();
  std::map<std::string, Setter> FirmwareKeys();
  std::map<std::string, Setter> PassKeys();
  std::map<std::string, Setter> GpioKeys();
  // The keys of a [section]; false: not a section.
  bool SectionKeys(const std::string& key, std::map<std::string, Setter>* keys);
  // The file's top level: scalars, sections, [[fault]].
  bool ReadKeys();
  // [[fault]] tables into s.faults (each with its line for later messages).
  bool ReadFaults(const toml::node& v);

  // A key's node, or the root when the key is absent (the message's line).
  const toml::node& at(const char* key) const {
    const toml::node* n = root_.at_path(key).node();
    return n != nullptr ? *n : static_cast<const toml::node&>(root_);
  }
  bool has(const char* key) const { return root_.at_path(key).node() != nullptr; }

  // [plant] params or preset, the damper they give, the [firmware] table file.
  bool CheckPlantFiles();
  // model = "structure": its [structure] record; the structure-only [pass] keys.
  bool CheckStructure();
  // model = "narx": the identified model file; its keys need that model.
  bool CheckNarx();
  // model = "quarter-car": [quarter_car] and [road]; the quarter-car-only [pass] keys.
  bool CheckQuarterCar();
  // model = "full-car": [full_car] and [road]; no [excitation], no faults or [gpio] (but
  // per-corner faults with [channels]).
  bool CheckFullCar();
  // [channels]: a full car, four CAN profiles (made absolute), the policy, the body law, the
  // law the corners run and the faults they take (scenario_checks_channels.cpp).
  bool CheckChannels();
  // [excitation] kind and what each kind needs.
  bool CheckExcitation();
  // [control] law and what each law needs (clipped-optimal: its gains file).
  bool CheckControl();
  // law = "clipped-optimal": a structure, and its gains file (made absolute).
  bool CheckClippedGains();
  // [pass] limits into s (those given), and the ones the excitation or law rules out.
  bool CheckPass();
  // Each fault within the run and with the lines it needs.
  bool CheckFaults();

  const std::string& path_;
  const toml::table& root_;
  std::string* error_;
  Ctx c_;
  double hb_ms_ = 0.0;
  std::string excitation_ = "periodic";
  int pass_max_viol_ = 0;
  double max_missed_ = -1.0, err_reach_ = -1.0, err_all_ = -1.0, replay_fit_ = -HUGE_VAL;
  int expect_exit_ = -1;
  std::string model_ = "damper", road_class_ = "C";
  const toml::table* spencer_ = nullptr;  // [plant.spencer] overrides
  std::string model_file_;
  int model_iteration_ = -1;
  double envelope_margin_ = 0.1;
  std::shared_ptr<StructureSetup> structure_ = std::make_shared<StructureSetup>();
  std::string record_file_;
  double max_peak_force_ = -1.0;
  // [channels] keys read before their checks.
  std::vector<std::string> channel_profiles_;  // [channels] can_profiles as given
  std::vector<std::string> channel_maps_;      // [channels] modbus_profiles as given
  double heave_ = -1.0, pitch_ = -1.0, roll_ = -1.0;
};

}  // namespace mrd::hil::scenario_reader
