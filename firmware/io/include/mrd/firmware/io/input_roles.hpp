#pragma once
// The device profiles' input roles (profile::CanIn, CAN and Modbus alike) that carry the
// firmware's inputs (Input), paired by name: the one lookup between the two enums, for the
// device side (field devices and the config's routing checks; they link mrd::profile). The
// roles past the inputs (sensor seq, driver faults and current, grant) feed no input.
//
// The compiler checks the table: one entry per input in Input's order, each role a distinct
// CanIn, so an input added without its role (or a role given twice) does not build.

#include <cstddef>
#include <iterator>

#include "mrd/firmware/io/io_config.hpp"
#include "mrd/profile/can_profile.hpp"

namespace mrd::firmware {

struct InputRole {
  Input input;
  profile::CanIn role;
};

inline constexpr InputRole kInputRoles[] = {
    {Input::kVelocity, profile::CanIn::kVelocity},
    {Input::kDisplacement, profile::CanIn::kDisplacement},
    {Input::kDemand, profile::CanIn::kDemand},
    {Input::kBodyVelocity, profile::CanIn::kBodyVelocity},
    {Input::kForce, profile::CanIn::kForce},
    {Input::kFaultLine, profile::CanIn::kFaultLine},
    {Input::kBodyAcceleration, profile::CanIn::kBodyAcceleration},
    {Input::kWheelVelocity, profile::CanIn::kWheelVelocity},
    {Input::kFloorAcceleration1, profile::CanIn::kFloorAcceleration1},
    {Input::kFloorAcceleration2, profile::CanIn::kFloorAcceleration2},
    {Input::kFloorAcceleration3, profile::CanIn::kFloorAcceleration3},
};
static_assert(std::size(kInputRoles) == kNumInputs, "every firmware input needs its profile role");

namespace input_roles_detail {
// Entry i is Input i (the table is indexed by Input).
constexpr bool InInputOrder() {
  for (std::size_t i = 0; i < std::size(kInputRoles); ++i) {
    if (static_cast<std::size_t>(kInputRoles[i].input) != i) return false;
  }
  return true;
}
// Every role is a CanIn and no two inputs share one.
constexpr bool DistinctRoles() {
  for (std::size_t i = 0; i < std::size(kInputRoles); ++i) {
    if (static_cast<std::size_t>(kInputRoles[i].role) >= profile::kNumCanIn) return false;
    for (std::size_t j = 0; j < i; ++j) {
      if (kInputRoles[j].role == kInputRoles[i].role) return false;
    }
  }
  return true;
}
}  // namespace input_roles_detail
static_assert(input_roles_detail::InInputOrder(), "kInputRoles lists the inputs in Input's order");
static_assert(input_roles_detail::DistinctRoles(), "each input has its own profile role");

// The profile role that carries an input, and its index in a profile's role arrays.
constexpr profile::CanIn RoleOf(Input input) {
  return kInputRoles[static_cast<std::size_t>(input)].role;
}
constexpr std::size_t RoleIndex(Input input) { return static_cast<std::size_t>(RoleOf(input)); }

}  // namespace mrd::firmware
