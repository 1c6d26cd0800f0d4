// A corrupt_table scenario (run_session.hpp RunCorruptTable): the firmware is offered a table
// with one flipped byte and must refuse it (exit 2) without ever driving the coil.
#include <fstream>

#include "run_internal.hpp"
#include "run_session.hpp"

namespace mrd::hil {

int RunCorruptTable(const Scenario& s, const RunOptions& o, PlantPort& port,
                    const std::function<void(std::int64_t)>& pump, const std::string& config,
                    RunResult* r, std::string* error) {
  std::string image;
  const std::string good = o.work_dir + "/table.bin";
  if (!o.table.empty()) {
    if (!ReadFile(o.table, &image)) {
      *error = o.table + ": cannot read";
      return 2;
    }
  } else {
    Child w;
    if (!w.Spawn({o.firmware, "--write-table", good}, o.work_dir + "/write_table.out",
                 o.work_dir + "/write_table.err", error)) {
      return 1;
    }
    if (w.Wait(10.0) != 0 || !ReadFile(good, &image)) {
      *error = "mrd-firmware --write-table failed";
      return 1;
    }
  }
  if (image.size() < 64) {
    *error = "table image too short";
    return 1;
  }
  image[image.size() / 2] = static_cast<char>(image[image.size() / 2] ^ 0x5A);
  const std::string bad = o.work_dir + "/corrupt_table.bin";
  std::ofstream(bad, std::ios::binary) << image;
  Child fw;
  const double dur = s.duration_s;
  if (!fw.Spawn(FirmwareArgv(o, config, bad, dur), o.work_dir + "/firmware.json",
                o.work_dir + "/firmware.err", error)) {
    return 1;
  }
  ++r->firmware_starts;
  // Listen meanwhile: a refusing firmware never sends a driving command.
  const std::int64_t until = common::MonotonicNs() + static_cast<std::int64_t>(5e9);
  DriverInput in;
  while (fw.Alive() && common::MonotonicNs() < until) {
    pump(2'000'000);
    DriverInput fresh;
    port.Poll(&fresh);
    if (fresh.has_command) {
      ++r->commands;
      if (!fresh.safe || fresh.volts != 0.0) ++r->driven_steps;
    }
  }
  r->firmware_exit = fw.Alive() ? fw.Stop(2.0) : fw.status();
  ReadFile(o.work_dir + "/firmware.err", &r->firmware_stderr);
  FaultResult fr;
  fr.fault = s.faults.front();
  fr.detection_required = false;
  const int expect = s.expect_firmware_exit.value_or(2);
  if (r->firmware_exit != expect) {
    fr.ok = false;
    fr.why = "firmware exit " + std::to_string(r->firmware_exit) + ", expected " +
             std::to_string(expect);
  } else if (r->driven_steps != 0) {
    fr.ok = false;
    fr.why = "the firmware drove the coil with a corrupt table";
  }
  r->faults.push_back(fr);
  return 0;
}

}  // namespace mrd::hil
