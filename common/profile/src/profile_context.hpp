#pragma once
// What every profile reader (CAN, CANopen, Modbus, PWM) shares: the "PATH:LINE: reason" error,
// the profile's folder (relative file names resolve against it) and the TOML parse whose syntax
// error names its line. Start-up only; toml++ throws, so the readers build with exceptions.

#include <toml++/toml.h>

#include <string>

namespace mrd::profile {

struct ProfileContext {
  const std::string& path;
  std::string* error;
  // Sets *error to "PATH:LINE: why" with the node's line (line 1 when at is null); false.
  bool Fail(const toml::node* at, const std::string& why) const;
  bool Fail(const toml::node& at, const std::string& why) const { return Fail(&at, why); }
};

// The folder of a profile file ("." for a bare name).
std::string ProfileDirectory(const std::string& path);

// Parses text into *root. false with *error "PATH:LINE: description" on a syntax error.
bool ParseProfileToml(const std::string& text, const std::string& path, toml::table* root,
                      std::string* error);

}  // namespace mrd::profile
