#pragma once
// A control law of mrd-firmware run in process on the quarter car (`mrd-hil study`): the
// firmware's own Controller at 1 kHz on the scenario's table (or the compiled-in one),
// configured by the firmware's own config parser, so every law name the parser knows
// ([control] law) runs here unchanged. Per period the plant's sample
// (damper velocity and displacement, body velocity, damper force) feeds Controller::Update
// and its command is held over the next period (no transport, no added delay), as in
// tests/common/quarter_car_skyhook_test.cpp. Deterministic.

#include <cstdint>
#include <string>

#include "mrd/common/table.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/hil/plants/ride.hpp"

namespace mrd::hil {

struct FirmwareLaw {
  std::string spec;                           // as given: NAME[:KEY=VALUE...]
  std::string name;                           // NAME
  firmware::platform::FirmwareConfig config;  // as the firmware parsed it
};

// spec: NAME or NAME:KEY=VALUE[:KEY=VALUE...] (keys of the firmware's [control] section, e.g.
// skyhook:skyhook_gain=40; a KEY with a dot names its section). skyhook_gain: the default
// of control.skyhook_gain (the scenario's); e_max [V]: control.e_max. false with *error
// ("--laws 'SPEC': reason", the parser's reason for an unknown law or key). sections: more
// config text appended after the law's (e.g. the scenario's [safety] keys, as `mrd-hil run`
// writes them).
bool MakeFirmwareLaw(const std::string& spec, double skyhook_gain, double e_max,
                     const std::string& sections, FirmwareLaw* out, std::string* error);

struct LawRun {
  RidePoint ride;                  // volts: the mean command [V]
  std::uint64_t violations = 0;    // commands non-finite or outside [0, E_max]
  std::uint64_t safe_periods = 0;  // watchdog safe state after the first period
};
// Runs the law on the plant from Reset on `table`. false with *error when the controller
// refuses the table or the configuration (CheckFirmwareLaw says so before any run).
bool RunFirmwareLaw(const FirmwareLaw& law, const CoefficientTable& table, QuarterCarPlant* plant,
                    double duration_s, double settle_s, LawRun* out, std::string* error);
// The controller's verdict on the law with the table: false with *error (the reason in words).
bool CheckFirmwareLaw(const FirmwareLaw& law, const CoefficientTable& table, std::string* error);

}  // namespace mrd::hil
