#pragma once
// The safe state proved before anything runs. For every bus that drives the current driver,
// what the wire carries in the firmware's safe state (the [safety] safe_voltage through the
// device profile's [command]) and at shutdown (0 V), computed with the codec the device sends
// with and decoded back: the set-point must be the driver's off (CommandMap::Off: 0, or the
// lowest of a range above 0) bit for bit, the enable 0 where the profile maps one; and every
// command in [0, E_max] must fit the set-point's signal or register (one beyond it would be
// refused on the wire and replaced by the safe state: no current when the most is asked).
// The profile loaders already refuse a [command] range beyond its signal and a shutdown that
// is not off (command_section); this adds the safe voltage, E_max and the routing.
// Configuration time only (allocates).

#include <string>
#include <vector>

#include "mrd/firmware/platform/config.hpp"

namespace mrd::firmware::platform {

struct SafeStateProof {
  std::vector<std::string> lines;  // per bus: what goes on the wire ("can: ...")
  std::string error;               // empty: proved; else why not
  const char* section = nullptr;   // the key to blame: [section] key ("safety" "safe_voltage",
  const char* key = nullptr;       // "control" "e_max", or the bus's "profile")
};

// e_max: the highest command [V] (the configuration's e_max, or the table's).
SafeStateProof ProveSafeState(const FirmwareConfig& c, double e_max);

}  // namespace mrd::firmware::platform
