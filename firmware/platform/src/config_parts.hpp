#pragma once
// The configuration reader's parts (config.hpp), shared by its files:
//   config_keys.cpp      every key: its parsing, default, unit and reference line (KeyTable)
//   config_checks.cpp    routing and connection checks across the bus sections (CheckIo)
//   config_profiles.cpp  the device profiles the bus sections name, loaded and checked
//   config_params.cpp    runtime parameters: list, set, what a reload may change
//   config.cpp           the file: sections in order, then checks, profiles, derived values
// Compiled with exceptions and RTTI (toml++ throws); the public functions catch everything.

#include <toml++/toml.h>

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "mrd/firmware/platform/config.hpp"

namespace mrd::firmware::platform::config_detail {

using Setter = std::function<bool(const toml::node&, std::string*)>;  // false: *why

// One configuration key: the single source of parsing, defaults and the reference
// (ConfigReference, docs/firmware_config.md).
struct Key {
  const char* name;
  Setter set;
  std::function<std::string()> show;  // current value as TOML ("" when unset)
  std::string accepts;                // accepted values in words
  const char* unit;                   // "" when none
  const char* description;
  const char* type = "";                // "float", "integer", "bool", "choice", "string", "list"
  Tunable tunable = Tunable::kRestart;  // when a change takes effect (params.hpp)
};

// Values kept in other units than the config's while the table is in use.
struct Scratch {
  double period_us;
  double max_age_ms;
  double e_max;
  bool e_max_set = false;
};

using Sections = std::vector<std::pair<std::string, std::vector<Key>>>;

// The key table, bound to c and scratch (which must outlive it), in the reference's order.
Sections KeyTable(FirmwareConfig* c, Scratch* x);

// v as a TOML float ("2.0", "0.5").
std::string Show(double v);

// "SOURCE:LINE: " of [section] key (or of the section when the key is absent; line 0 when
// neither is in root).
std::string Where(const toml::table& root, const std::string& source, const char* section,
                  const char* key);

// [channels] tables and can_profiles: a list of 1 ... kMaxChannels file names
// (config_channels.cpp); none_shown: the reference's default when the key is absent.
Key FileList(const char* name, std::vector<std::string>* out, const char* none_shown,
             const char* description);
// [channels] geometry key bit (ChannelsConfig::geometry_given): Number that records it was given.
Key GeometryKey(Key number, std::uint32_t* given, std::uint32_t bit);

// The [channels] section against the rest: count, tables and can_profiles, the body law's
// needs, no bus section but [can] (with can_profiles) with several channels; each table file
// loaded once to prove it loads (config_channels.cpp). Fills c->channels.table_paths.
bool CheckChannels(const toml::table& root, const std::string& source, FirmwareConfig* c,
                   std::string* error);

// Routing and connection checks across the bus sections (io_config.hpp), in this order (the
// first failing one is the error): clipped-optimal gains given, the grant clock without
// buses, routing, inputs the law reads, displacement limit, command output, connections,
// [gpio] lines.
bool CheckIo(const toml::table& root, const std::string& source, const FirmwareConfig& c,
             std::string* error);

// The device profile of each enabled bus section, loaded relative to the configuration file
// and checked against that section's routing (config_profiles.cpp). [can] with [channels]
// can_profiles: each channel's (c->channels.can_device_profiles; channel 0's also in
// c->io.can, the one the single-device paths read).
bool LoadCanProfileOf(const toml::table& root, const std::string& source, FirmwareConfig* c,
                      std::string* error);
bool LoadModbusProfileOf(const toml::table& root, const std::string& source, FirmwareConfig* c,
                         std::string* error);
bool LoadPwmProfileOf(const toml::table& root, const std::string& source, FirmwareConfig* c,
                      std::string* error);

}  // namespace mrd::firmware::platform::config_detail
