#pragma once
// Each `mrd` subcommand registers itself on the CLI11 app; its handler runs the command and
// throws InputError for bad input (exit 2) or std::exception for other failures (exit 1).

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "mrd/common/time_window.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host::cli {

// --window FROM:TO of the time plots: unset for "" (the default window); InputError (exit 2)
// for a malformed one.
inline std::optional<TimeWindow> WindowFlag(const std::string& text) {
  if (text.empty()) return std::nullopt;
  TimeWindow w;
  std::string why;
  if (!ParseTimeWindow(text, &w, &why)) throw InputError("", 0, "--window " + why);
  return w;
}
inline constexpr const char* kWindowHelp =
    "Time plots: the window drawn sample by sample, FROM:TO [s] (default: the first 5 s); an "
    "overview of the whole record (min/max envelope) is drawn below it";

void RegisterCompare(CLI::App& app);
void RegisterExport(CLI::App& app);
void RegisterFitSpencer(CLI::App& app);
void RegisterGenerate(CLI::App& app);
void RegisterImport(CLI::App& app);
void RegisterLog(CLI::App& app);
void RegisterReport(CLI::App& app);
void RegisterResid(CLI::App& app);
void RegisterSlice(CLI::App& app);
void RegisterIdentify(CLI::App& app);
void RegisterSimulate(CLI::App& app);

}  // namespace mrd::host::cli
