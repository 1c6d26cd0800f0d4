// The configuration file (config.hpp): sections and keys in order, then the routing checks,
// the files the keys name, the device profiles and the derived values. Compiled with exceptions
// and RTTI (toml++ needs them); every exception is caught here. The parts: config_parts.hpp.
#include <cmath>
#include <cstdlib>

#include "config_parts.hpp"
#include "mrd/common/file_path.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/firmware/builtin_table.hpp"
#include "mrd/firmware/platform/clipped_optimal_file.hpp"
#include "mrd/firmware/platform/period_log.hpp"
#include "mrd/firmware/platform/safe_state.hpp"

namespace mrd::firmware::platform {

using config_detail::CheckChannels;
using config_detail::CheckIo;
using config_detail::Key;
using config_detail::KeyTable;
using config_detail::LoadCanProfileOf;
using config_detail::LoadModbusProfileOf;
using config_detail::LoadPwmProfileOf;
using config_detail::Scratch;
using config_detail::Sections;
using config_detail::Where;

namespace {

bool Apply(const toml::table& root, const std::string& source, FirmwareConfig* c,
           std::string* error) {
  Scratch x{static_cast<double>(c->period_ns) / 1e3,
            static_cast<double>(c->controller.watchdog.max_age_ns) / 1e6, c->e_max.value_or(NAN)};
  ControllerConfig& k = c->controller;
  const Sections sections = KeyTable(c, &x);
  auto fail = [&](const toml::node& n, const std::string& what) {  // what may echo input
    *error = source + ":" + std::to_string(n.source().begin.line) + ": " + Printable(what);
    return false;
  };
  for (const auto& [name, node] : root) {
    const auto section = std::find_if(sections.begin(), sections.end(),
                                      [&](const auto& sec) { return sec.first == name.str(); });
    if (section == sections.end())
      return fail(node, "unknown section '" + std::string(name.str()) + "'");
    const toml::table* tbl = node.as_table();
    if (tbl == nullptr)
      return fail(node, std::string("'").append(name.str()).append("' must be a table"));
    if (name.str() == "can") c->io.can.enabled = true;
    if (name.str() == "modbus") c->io.modbus.enabled = true;
    if (name.str() == "gpio") c->io.gpio.enabled = true;
    if (name.str() == "pwm") c->io.pwm.enabled = true;
    for (const auto& [key, value] : *tbl) {
      const auto entry = std::find_if(section->second.begin(), section->second.end(),
                                      [&](const Key& e) { return key.str() == e.name; });
      if (entry == section->second.end()) {
        return fail(value,
                    "unknown key '" + std::string(key.str()) + "' in [" + section->first + "]");
      }
      std::string why;
      if (!entry->set(value, &why)) {
        return fail(value, std::string("'").append(key.str()).append("' ").append(why));
      }
    }
  }
  if (!CheckChannels(root, source, c, error)) return false;  // several channels: no bus
  if (!CheckIo(root, source, *c, error)) return false;
  if (!c->clipped_gains_path.empty()) {  // relative to the config file
    const std::string path = ResolveBeside(source, c->clipped_gains_path);
    std::string why;
    if (!LoadClippedOptimalGains(path, &k.clipped_gains, &why)) {
      *error = Where(root, source, "clipped_optimal", "gains") +
               "[clipped_optimal] gains: " + Printable(why);
      return false;
    }
    k.clipped_gains_loaded = true;
  }
  if (c->io.can.enabled && !LoadCanProfileOf(root, source, c, error)) return false;
  if (c->io.modbus.enabled && !LoadModbusProfileOf(root, source, c, error)) return false;
  if (c->io.pwm.enabled && !LoadPwmProfileOf(root, source, c, error)) return false;
  // Relative to the config file; beside a bare config name it already is (kept as given).
  if (!c->log.path.empty() && source.find('/') != std::string::npos) {
    c->log.path = ResolveBeside(source, c->log.path);
  }
  runlog::Header log_header;
  log_header.fields = PeriodLogFields();
  const std::uint64_t block_bytes =
      runlog::kBlockHeaderBytes + std::uint64_t{c->log.block_records} * log_header.record_bytes();
  if (runlog::EncodeHeader(log_header).size() + block_bytes > c->log.max_bytes) {
    *error = Where(root, source, "log", "max_bytes") + "[log] max_bytes " +
             std::to_string(c->log.max_bytes) + " is smaller than the header and one block of " +
             std::to_string(c->log.block_records) + " records (" + std::to_string(block_bytes) +
             " bytes)";
    return false;
  }
  c->period_ns = static_cast<std::int64_t>(std::llround(x.period_us * 1e3));
  k.watchdog.max_age_ns = static_cast<std::int64_t>(std::llround(x.max_age_ms * 1e6));
  if (x.e_max_set) c->e_max = x.e_max;
  if (!c->ctl_socket.empty()) c->ctl_enable = true;
  // Grants travel on CAN when there is a CAN bus, else on Modbus.
  c->io.can.lockstep = c->clock == LoopClock::kGrant;
  c->io.modbus.lockstep = c->clock == LoopClock::kGrant && !c->io.can.enabled;
  c->io.can.max_age_ns = k.watchdog.max_age_ns;  // the CAN device's last check before sending
  c->io.modbus.priority = c->priority;           // the worker that writes the loop's safe block
  c->io.can.period_ns = c->period_ns;
  c->io.modbus.period_ns = c->period_ns;
  c->io.pwm.period_ns = c->period_ns;
  c->io.pwm.safe_volts = k.safe_voltage;
  // The safe state on the wire (E_max: the configuration's, else the compiled-in table's; the
  // start proves it again with the table it runs on).
  const SafeStateProof proof = ProveSafeState(*c, c->e_max.value_or(kBuiltinTable.e_max));
  if (!proof.error.empty()) {
    *error = Where(root, source, proof.section, proof.key) + Printable(proof.error);
    return false;
  }
  return true;
}

// The words before a section's key table in the reference ("" for none).
std::string SectionIntro(const std::string& section) {
  if (section != "channels") return "";
  return "Several damper channels on one loop (one controller board, four corners of a car):\n"
         "each channel has its table, its watchdog and its counters; all run on the one period\n"
         "in channel order. They run on one CAN bus, each channel on its own device with its own\n"
         "profile (`can_profiles`, e.g. four CANopen drives: docs/guide/board.md, \"Several\n"
         "dampers on one board\"; the `[can]` section is the bus, its routing and timing shared\n"
         "by all), on one Modbus link, each channel on its own register map (`modbus_profiles`,\n"
         "e.g. one driver with a set-point block per corner; the `[modbus]` section is the link,\n"
         "its routing and timing shared by all; one master, one request sequence), or with\n"
         "`--dry-run`, each on a simulated damper of its own (channel i: the [simulation] stroke\n"
         "8 i % smaller and the body velocity i/8 of a period later). One bus serves the channels\n"
         "in this version (not both lists); `[gpio]` and `[pwm]` serve one channel only (refused\n"
         "with `count > 1`), as `[can]` without `can_profiles` and `[modbus]` without\n"
         "`modbus_profiles` do. The `--json` summary's top-level\n"
         "counters are channel 0's; `fault_policy` and a `channels` array (each channel's table,\n"
         "counters, trips per cause, final safe state, the causes of its last period and, on\n"
         "the bus, its `device`) follow. The per-period log records channel 0; the runtime\n"
         "parameters serve one channel only (`[ctl]` with `count > 1` is refused, a reload\n"
         "(SIGHUP) is not applied). Example, four corners under modal skyhook (front-left,\n"
         "front-right, rear-left, rear-right):\n\n"
         "```toml\n"
         "[control]\n"
         "law = \"force\"              # the body law sets each corner's force demand\n"
         "[channels]\n"
         "count = 4\n"
         "fault_policy = \"all\"       # a fault on one corner puts all four safe\n"
         "tables = [\"front.bin\", \"front.bin\", \"rear.bin\", \"rear.bin\"]\n"
         "body_law = \"modal-skyhook\"\n"
         "cg_to_front_m = 1.2\n"
         "cg_to_rear_m = 1.4\n"
         "track_front_m = 1.5\n"
         "track_rear_m = 1.5\n"
         "motion_ratio = 0.7\n"
         "heave_n_s_per_m = 16800\n"
         "```\n\n"
         "`mrd-firmware --config car.toml --dry-run 10 --lockstep --json` then reports each\n"
         "corner. Default gains: per-corner skyhook of 60 N s/cm on the default geometry. On a\n"
         "CAN bus, with the shipped four-corner CANopen profiles:\n\n"
         "```toml\n"
         "[channels]\n"
         "count = 4\n"
         "can_profiles = [\"canopen-corner-fl.toml\", \"canopen-corner-fr.toml\",\n"
         "                \"canopen-corner-rl.toml\", \"canopen-corner-rr.toml\"]\n"
         "[can]\n"
         "interface = \"can0\"           # no `profile` here: one per channel above\n"
         "inputs = [\"velocity\", \"displacement\", \"demand\", \"body_velocity\"]\n"
         "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n"
         "```\n\n"
         "On one Modbus link, with the shipped four-corner maps (one sensor module, one driver\n"
         "with four set-points):\n\n"
         "```toml\n"
         "[channels]\n"
         "count = 4\n"
         "modbus_profiles = [\"modbus-corner-fl.toml\", \"modbus-corner-fr.toml\",\n"
         "                   \"modbus-corner-rl.toml\", \"modbus-corner-rr.toml\"]\n"
         "[modbus]\n"
         "mode = \"rtu\"\n"
         "device = \"/dev/ttyUSB0\"      # no `profile` here: one per channel above\n"
         "inputs = [\"velocity\", \"displacement\", \"demand\", \"body_velocity\"]\n"
         "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n"
         "```\n\n";
}

}  // namespace

std::string ConfigReference() {
  try {
    FirmwareConfig c;
    Scratch x{static_cast<double>(c.period_ns) / 1e3,
              static_cast<double>(c.controller.watchdog.max_age_ns) / 1e6, 2.25};
    std::string out =
        "# mrd-firmware configuration reference\n\n"
        "Generated by `mrd-firmware --print-config-reference` from the key table in\n"
        "`firmware/platform/src/config_keys.cpp` (a test checks that this file equals its "
        "output).\n\n"
        "`mrd-firmware --config FILE.toml` reads TOML once at start-up. Every key is optional;\n"
        "an unknown section or key, a wrong type or a value out of range is an error\n"
        "(`error: FILE:LINE: reason`, exit 2; input the reason echoes is shown with control\n"
        "bytes as `\\xNN` and cut at 400 characters). The file must be a regular file of at most\n"
        "1 MiB (a directory, FIFO or device is refused without reading it). `--check-config`\n"
        "refuses every value the start would refuse for its form (routing, lengths,\n"
        "characters); an interface, host or device that is missing shows only at start.\n\n"
        "Column *set*: `runtime` keys can change while the firmware runs (`mrd-firmware ctl\n"
        "set`, applied at a period boundary; docs/tuning.md) and on a reload (SIGHUP);\n"
        "`reload` keys on a reload only; `restart` keys need a restart (a reload that changes\n"
        "one is refused).\n";
    for (const auto& [section, keys] : KeyTable(&c, &x)) {
      out += "\n## [" + section + "]\n\n" + SectionIntro(section);
      out += "| key | default | unit | accepts | set | meaning |\n|---|---|---|---|---|---|\n";
      for (const Key& key : keys) {
        const std::string def = key.show();
        std::string accepts;  // '|' would end the Markdown cell
        for (const char ch : key.accepts)
          accepts += ch == '|' ? std::string("or") : std::string(1, ch);
        out += std::string("| `") + key.name + "` | " +
               (def.empty()     ? std::string("table's")
                : def[0] == '(' ? def.substr(1, def.size() - 2)
                                : "`" + def + "`") +
               " | " + key.unit + " | " + accepts + " | " + TunableName(key.tunable) + " | " +
               key.description + " |\n";
      }
    }
    return out;
  } catch (const std::exception&) {
    return "";
  }
}

const char* TunableName(Tunable t) {
  switch (t) {
    case Tunable::kRestart:
      return "restart";
    case Tunable::kReload:
      return "reload";
    case Tunable::kRuntime:
      return "runtime";
  }
  return "restart";
}

std::string DefaultCtlSocket() {
  const char* xdg = std::getenv("XDG_RUNTIME_DIR");
  if (xdg != nullptr && xdg[0] == '/') return std::string(xdg) + "/mrd-firmware.sock";
  return "/run/mrd-firmware/ctl.sock";
}

bool ParseConfig(std::string_view text, const std::string& source, FirmwareConfig* config,
                 std::string* error) {
  try {
    const std::string shown = Printable(source);  // messages echo it
    try {
      const toml::table root = toml::parse(text, source);
      FirmwareConfig c = *config;
      if (!Apply(root, shown, &c, error)) return false;
      *config = c;
      return true;
    } catch (const toml::parse_error& e) {
      *error =
          shown + ":" + std::to_string(e.source().begin.line) + ": " + Printable(e.description());
      return false;
    }
  } catch (const std::exception& e) {  // std::bad_alloc
    *error = Printable(source) + ": " + e.what();
    return false;
  }
}

bool LoadConfigFile(const std::string& path, FirmwareConfig* config, std::string* error) {
  try {
    std::string text;
    if (!ReadInputFile(path, kMaxConfigBytes, &text, error)) return false;
    return ParseConfig(text, path, config, error);
  } catch (const std::exception& e) {  // std::bad_alloc
    *error = Printable(path) + ": " + e.what();
    return false;
  }
}

}  // namespace mrd::firmware::platform
