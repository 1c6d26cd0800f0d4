#pragma once
// Reading a profile's [canopen] table (canopen_profile.hpp) inside ParseCanProfile: after the
// DBC and the roles (the COB-ID collision check needs both). toml++ throws: compiled with
// exceptions, called inside can_profile.cpp's try block.
#include <toml++/toml.h>

#include <string>

#include "mrd/profile/can_profile.hpp"

namespace mrd::profile {

// false with *error "FILE:LINE: reason" (the profile's line, or the DBC's for a colliding
// message).
bool ParseCanopenSection(const toml::table& t, const std::string& path, CanProfile* p,
                         std::string* error);

}  // namespace mrd::profile
