#pragma once
// mrd-hil's check of a coefficient table before a run: a table the firmware would refuse at
// start-up is bad input, said before anything runs or is written. And the names every summary,
// table and plot gives the table (path and CRC) and the plant a run used.

#include <string>

#include "mrd/common/table.hpp"
#include "mrd/hil/scenario/scenario.hpp"

namespace mrd::hil {

// true for an empty path (the firmware's built-in table) or a table the firmware accepts;
// false after printing "error: FILE: reason" (firmware::platform::LoadTableFile's words) to stderr.
bool TableIsUsable(const std::string& path);

// The table a run uses: the file at `path`, or the firmware's compiled-in table for "". false
// after printing "error: FILE: reason" to stderr.
bool LoadRunTable(const std::string& path, CoefficientTable* table);

// "PATH (CRC-32 0x1234ABCD)", or "compiled-in (CRC-32 0x...)" for an empty path: the CRC of
// the table's image (the one `mrd export` prints and the file carries in its last 4 bytes).
std::string TableLabel(const std::string& path, const CoefficientTable& table);

// The plant a scenario runs: "Spencer damper, preset paper" or "Spencer damper, params FILE",
// with " + [plant.spencer] overrides" when it has them; "NARX model FILE (iteration N)";
// "three-story structure" (its damper as above); prefixed "quarter car, " for a quarter car.
std::string PlantLabel(const Scenario& s);

}  // namespace mrd::hil
