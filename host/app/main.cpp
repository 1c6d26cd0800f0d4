// mrd — host CLI of the MR damper control toolkit.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>

#include "commands.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/input_error.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "mrd: identify control-oriented NARX models of magneto-rheological dampers.\n"
      "Data flow: generate | import -> identify -> simulate/report/compare/resid -> export (table "
      "for "
      "mrd-firmware)."};
  mrd::host::InstallCleanupHandlers();
  app.require_subcommand(1);
  mrd::host::cli::RegisterGenerate(app);
  mrd::host::cli::RegisterExport(app);
  mrd::host::cli::RegisterImport(app);
  mrd::host::cli::RegisterSlice(app);
  mrd::host::cli::RegisterIdentify(app);
  mrd::host::cli::RegisterSimulate(app);
  mrd::host::cli::RegisterReport(app);
  mrd::host::cli::RegisterCompare(app);
  mrd::host::cli::RegisterResid(app);
  mrd::host::cli::RegisterLog(app);
  mrd::host::cli::RegisterFitSpencer(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : mrd::host::kExitBadInput;
  } catch (const mrd::host::InputError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return mrd::host::kExitBadInput;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
  // The result on stdout (e.g. simulate --json) is output too: a failed write is an error.
  if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
    fmt::print(stderr, "error: cannot write to standard output: {}\n", std::strerror(errno));
    return 1;
  }
  return 0;
}
