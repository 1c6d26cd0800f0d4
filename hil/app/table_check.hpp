#pragma once
// mrd-hil's check of a coefficient table before a run: a table the firmware would refuse at
// start-up is bad input, said before anything runs or is written.

#include <string>

namespace mrd::hil {

// true for an empty path (the firmware's built-in table) or a table the firmware accepts;
// false after printing "error: FILE: reason" (firmware::LoadTableFile's words) to stderr.
bool TableIsUsable(const std::string& path);

}  // namespace mrd::hil
