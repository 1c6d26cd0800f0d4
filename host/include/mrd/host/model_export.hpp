#pragma once
// A model file's iteration as the firmware's coefficient table, the one path `mrd export` and
// Python's Model.table take: the inverted input checked, the command range chosen
// (command_range.hpp), the table built with the operating envelope and validated once, and the
// invertibility over that range checked and recorded in it (invertibility.hpp). Whether a
// non-invertible model may be written is the caller's choice.

#include <optional>
#include <string>

#include "mrd/common/table.hpp"
#include "mrd/host/command_range.hpp"
#include "mrd/host/invertibility.hpp"
#include "mrd/host/model_file.hpp"

namespace mrd::host {

struct ExportRequest {
  int iteration = 0;
  std::string input = "E";             // the inverted input channel
  std::optional<double> e_min, e_max;  // [V]; none: command_range.hpp's rules
  std::string profile;                 // device profile whose command range applies ("" none)
};

struct ExportedTable {
  CoefficientTable table;  // validated, with its invertibility record
  CommandRange range;      // the range it was exported for, where from, and its warnings
  bool envelope = false;   // the model file had an operating envelope (table v2 and later)
  InvertibilityReport invertibility;
};

// Throws InputError(m.path, 0, reason), in this order, when the iteration does not exist, the
// input is not an input signal its terms read, the profile does not load, or the table does not
// validate (range, capacity).
ExportedTable ExportCheckedTable(const ModelFile& m, const ExportRequest& request);

// Copies the operating envelope of the model file's channels (min, max of the identification
// data) into the table, per table channel by name. False (table unchanged) when a channel has
// no recorded range (model files written before the envelope existed).
bool SetTableEnvelope(const ModelFile& m, CoefficientTable* table);

// The runtime model of iteration k when `input` (normally "E") is an input signal its terms
// read; throws InputError(m.path, 0, reason) otherwise.
mrd::Model CheckExportInput(const ModelFile& m, int k, const std::string& input);

}  // namespace mrd::host
