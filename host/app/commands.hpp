#pragma once
// Each `mrd` subcommand registers itself on the CLI11 app; its handler runs the command and
// throws InputError for bad input (exit 2) or std::exception for other failures (exit 1).

#include <CLI/CLI.hpp>

namespace mrd::host::cli {

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
