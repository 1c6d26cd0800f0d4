// A HIL scenario against an mrd-firmware child (hil/run.hpp), as `mrd-hil run` runs it: the
// scenario with its overrides, the table checked first, the passive baseline of a quarter car,
// and the summary of `mrd-hil run --json` as a dict (hil/app/report.hpp). It runs beside the
// interpreter; Ctrl-C stops the run (the firmware child gets SIGINT) and raises
// KeyboardInterrupt.
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/firmware/platform/table_file.hpp"
#include "mrd/hil/run/run.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/hil/study/passive_baseline.hpp"
#include "report.hpp"
#include "table_check.hpp"

namespace mrd::python {
namespace {

// The scenario as `mrd-hil run` prepares it; ValueError/OSError with its words.
hil::Scenario LoadScenario(const std::string& path, const std::vector<std::string>& sets,
                           const std::optional<double>& passive_step) {
  hil::Scenario s;
  std::string error;
  if (!hil::LoadScenario(path, sets, &s, &error)) {
    Rethrow(host::InputError("", 0, error), {path});
  }
  if (passive_step) {
    if (!s.quarter_car) throw BadInput("passive_step: " + s.path + " is not a quarter car");
    if (!(*passive_step >= 0.0 && *passive_step <= 1e3)) {
      throw BadInput("passive_step: must be in [0, 1000] V");
    }
    if (*passive_step > 0.0 && s.e_max / *passive_step > 10000.0) {
      throw BadInput("passive_step " + std::to_string(*passive_step) +
                     ": more than 10000 grid points over 0 .. E_max");
    }
    s.passive_step_v = *passive_step;
  }
  return s;
}

// Removes a temporary work directory on every way out.
struct TempDir {
  std::string path;
  ~TempDir() {
    if (path.empty()) return;
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

py::object RunScenario(const py::object& scenario, const std::vector<std::string>& sets,
                       const std::string& firmware, const py::object& table, const py::object& out,
                       const std::string& transport, const std::string& clock,
                       const py::object& profile, std::optional<double> passive_step,
                       double startup_timeout, double command_timeout, const py::object& progress) {
  const std::string path = PathOf(scenario);
  hil::Scenario s = LoadScenario(path, sets, passive_step);
  hil::RunOptions o;
  o.transport = transport;
  o.clock = clock;
  if (!table.is_none()) o.table = PathOf(table);
  if (!profile.is_none()) o.profile = PathOf(profile);
  o.firmware = firmware;
  o.startup_timeout_s = startup_timeout;
  o.command_timeout_s = command_timeout;
  if (!(startup_timeout >= 0.1 && startup_timeout <= 3600.0) ||
      !(command_timeout >= 0.1 && command_timeout <= 3600.0)) {
    throw BadInput("startup_timeout and command_timeout must be in [0.1, 3600] s");
  }
  if (::access(o.firmware.c_str(), X_OK) != 0) {
    throw FileError(Printable(o.firmware) + ": not an executable (give firmware=PATH)", errno,
                    false);
  }
  // The table the firmware would refuse at start-up is bad input, said before anything runs.
  const std::string table_path = o.table.empty() ? s.table_file : o.table;
  if (!table_path.empty()) {
    std::string reason;
    if (!firmware::platform::LoadTableFile(table_path.c_str(), &reason).ok()) {
      Rethrow(host::InputError("", 0, Printable(table_path) + ": " + reason), {table_path});
    }
  }
  TempDir temp;
  if (!out.is_none()) {
    const std::string dir = PathOf(out);
    std::error_code ec;
    if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec)) {
      throw FileError("out " + Printable(dir) + ": exists and is not a directory", ENOTDIR, false);
    }
    o.work_dir = dir;
    o.firmware_log = "firmware.mrdlog";  // beside trace.csv, as mrd-hil run --out
  } else {
    char dir[] = "/tmp/mrd-hil-XXXXXX";
    if (::mkdtemp(dir) == nullptr)
      throw FileError("cannot create a temporary directory", errno, false);
    temp.path = o.work_dir = dir;
  }
  o.keep_trace = true;

  std::atomic<int> interrupt{0};
  o.interrupt = &interrupt;
  Beside beside;
  hil::RunResult r;
  std::string error;
  int rc = 0;
  beside.Run(
      [&] {
        rc = hil::RunScenario(s, o, &r, &error);
        if (rc != 0 || !r.ride || s.passive_step_v <= 0.0) return;
        hil::PassiveBaseline b;  // the best passive baseline of a quarter car (in process)
        const bool ok = hil::ComputePassiveBaseline(
            s, r, s.passive_step_v, &b, [&](std::size_t i, std::size_t n) {
              if (i % 10 == 0 || i == n) {
                beside.Note("passive grid: " + std::to_string(i) + "/" + std::to_string(n));
              }
              return interrupt.load() == 0;
            });
        if (ok) r.passive = std::move(b);
      },
      [&](const std::string& line) {
        if (!progress.is_none()) progress(line);
      },
      [&] { interrupt.store(SIGINT); });
  if (rc != 0) {
    std::string text = error;
    if (!r.firmware_stderr.empty()) text += "\nfirmware: " + r.firmware_stderr;
    if (rc == 2) throw BadInput(text);
    throw std::runtime_error(text);
  }
  nlohmann::json summary = hil::SummaryJson(s, r);
  CoefficientTable run_table;  // what the run used, named as mrd-hil run names it
  if (!hil::LoadRunTable(table_path, &run_table)) throw BadInput(table_path + ": unreadable");
  summary["table"] = hil::TableLabel(table_path, run_table);
  summary["plant"] = hil::PlantLabel(s);
  if (!out.is_none()) {
    std::string werror, warning;
    if (!hil::WriteOutputs(o.work_dir, summary, r, nullptr, &werror, &warning)) {
      throw FileError(werror, 0, false);
    }
    if (!warning.empty() && !progress.is_none()) progress("warning: " + warning);
  }
  return FromJson(summary);
}

}  // namespace

void RegisterRuns(py::module_& m) {
  m.def("_run_scenario", &RunScenario, py::arg("scenario"), py::arg("sets"), py::arg("firmware"),
        py::arg("table"), py::arg("out"), py::arg("transport"), py::arg("clock"),
        py::arg("profile"), py::arg("passive_step"), py::arg("startup_timeout"),
        py::arg("command_timeout"), py::arg("progress"));
}

}  // namespace mrd::python
