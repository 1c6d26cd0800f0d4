#pragma once
// The firmware's laws on the full car (`mrd-hil study` on a full-car scenario): one firmware
// Controller per corner at 1 kHz on the scenario's table, as firmware_law.hpp runs one on the
// quarter car. Per-corner laws (skyhook, groundhook, sh-add, ...: firmware_law.hpp's specs) read
// their own corner's signals; "modal-skyhook[:heave=C:pitch=C:roll=C]" runs the firmware's
// ModalSkyhook (modal_skyhook.hpp) on the four corners' body velocities, its demands tracked
// by the four Controllers on law "force" (clamped, inverted). Gains: heave [N s/m], pitch and
// roll [N m s/rad]; defaults ModalGains'. Geometry and motion ratio: the scenario's car.
// Deterministic.

#include <cstdint>
#include <string>

#include "firmware_law.hpp"
#include "mrd/firmware/modal_skyhook.hpp"
#include "mrd/hil/plants/full_car_ride.hpp"

namespace mrd::hil {

struct FullCarLawSpec {
  FirmwareLaw law;  // per corner (modal: law "force")
  bool modal = false;
  firmware::ModalGains gains;
};

// As MakeFirmwareLaw, plus "modal-skyhook" with its gains; false with *error ("--laws 'SPEC':
// reason").
bool MakeFullCarLaw(const std::string& spec, double skyhook_gain, double e_max,
                    const std::string& sections, FullCarLawSpec* out, std::string* error);

struct FullCarLawRun {
  FullCarRidePoint ride;           // volts_front / volts_rear: the mean commands [V]
  std::uint64_t violations = 0;    // commands non-finite or outside [0, E_max]
  std::uint64_t safe_periods = 0;  // corner-periods in the safe state after the first period
};
// Runs the law on the plant from Reset. false with *error when the controller refuses the
// table or the configuration, or the modal skyhook the car's geometry.
bool RunFullCarLaw(const FullCarLawSpec& law, const CoefficientTable& table, FullCarPlant* plant,
                   double duration_s, double settle_s, FullCarLawRun* out, std::string* error);

}  // namespace mrd::hil
