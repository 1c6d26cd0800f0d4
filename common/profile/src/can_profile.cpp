// Loading a CAN device profile (can_profile.hpp). toml++ reports errors by exception: this
// file alone is compiled with exceptions and catches them all.
#include "mrd/profile/can_profile.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string_view>

#include "canopen_section.hpp"
#include "command_section.hpp"
#include "file_text.hpp"
#include "profile_context.hpp"

namespace mrd::profile {
namespace {

constexpr const char* kCanInNames[kNumCanIn] = {"velocity",
                                                "displacement",
                                                "demand",
                                                "body_velocity",
                                                "force",
                                                "fault_line",
                                                "body_acceleration",
                                                "wheel_velocity",
                                                "floor_acceleration_1",
                                                "floor_acceleration_2",
                                                "floor_acceleration_3",
                                                "sensor_seq",
                                                "driver_faults",
                                                "driver_current",
                                                "grant"};
constexpr const char* kCanOutNames[kNumCanOut] = {"command",
                                                  "enable",
                                                  "enable_valid",
                                                  "safe",
                                                  "echo",
                                                  "heartbeat_safe",
                                                  "status_safe",
                                                  "status_causes",
                                                  "status_overruns",
                                                  "status_safe_entries",
                                                  "status_model_force",
                                                  "status_demand",
                                                  "status_command",
                                                  "fault_reset"};

// "Message.Signal" -> indices in the DBC.
bool Resolve(const ProfileContext& c, const toml::node& n, const std::string& key, const Dbc& dbc,
             SignalRef* out) {
  const auto v = n.value<std::string>();
  if (!v) return c.Fail(&n, key + ": expected \"Message.Signal\" (a string)");
  const auto dot = v->find('.');
  if (dot == std::string::npos) return c.Fail(&n, key + ": '" + *v + "' is not Message.Signal");
  const std::string msg = v->substr(0, dot), sig = v->substr(dot + 1);
  for (std::size_t m = 0; m < dbc.messages.size(); ++m) {
    if (dbc.messages[m].name != msg) continue;
    const auto& sigs = dbc.messages[m].signals;
    for (std::size_t s = 0; s < sigs.size(); ++s) {
      if (sigs[s].name == sig) {
        *out = {static_cast<int>(m), static_cast<int>(s)};
        return true;
      }
    }
    return c.Fail(&n, key + ": message " + msg + " of " + dbc.path + " has no signal " + sig);
  }
  return c.Fail(&n, key + ": " + dbc.path + " has no message " + msg);
}

int SignalIndex(const DbcMessage& m, std::string_view name) {
  for (std::size_t s = 0; s < m.signals.size(); ++s) {
    if (m.signals[s].name == name) return static_cast<int>(s);
  }
  return -1;
}

bool Byte(const ProfileContext& c, const toml::node& n, const std::string& key, std::uint8_t* out) {
  const auto v = n.value<std::int64_t>();
  if (!v || *v < 0 || *v > 255) return c.Fail(&n, key + ": expected an integer 0..255");
  *out = static_cast<std::uint8_t>(*v);
  return true;
}

bool Millis(const ProfileContext& c, const toml::node& n, const std::string& key, double lo,
            double hi, std::int64_t* out_ns) {
  const auto v = n.value<double>();
  if (!v || !std::isfinite(*v) || *v < lo || *v > hi) {
    return c.Fail(&n, key + ": expected milliseconds in [" + std::to_string(lo) + ", " +
                          std::to_string(hi) + "]");
  }
  *out_ns = static_cast<std::int64_t>(std::llround(*v * 1e6));
  return true;
}

bool Message(const ProfileContext& c, const toml::table& t, const std::string& name,
             CanProfile* p) {
  const Dbc& dbc = p->dbc;
  int index = -1;
  for (std::size_t m = 0; m < dbc.messages.size(); ++m) {
    if (dbc.messages[m].name == name) index = static_cast<int>(m);
  }
  const std::string at = "messages." + name;
  if (index < 0) return c.Fail(&t, at + ": " + dbc.path + " has no message " + name);
  const DbcMessage& m = dbc.messages[static_cast<std::size_t>(index)];
  MessageSpec& spec = p->specs[static_cast<std::size_t>(index)];
  for (const auto& [k, v] : t) {
    const std::string key(k.str());
    const std::string full = at + "." + key;
    if (key == "counter" || key == "checksum") {
      const auto s = v.value<std::string>();
      const int si = s ? SignalIndex(m, *s) : -1;
      if (si < 0) return c.Fail(&v, full + ": expected the name of a signal of " + name);
      for (std::size_t r = 0; r < kNumCanIn + kNumCanOut; ++r) {
        const SignalRef ref = r < kNumCanIn ? p->inputs[r] : p->outputs[r - kNumCanIn];
        // A sensor frame's rolling counter may be its sample number too (sensor_seq): it
        // counts the frames the sensor sends.
        if (key == "counter" && r == static_cast<std::size_t>(CanIn::kSensorSeq)) continue;
        if (ref.message == index && ref.signal == si) {
          return c.Fail(&v, full + ": the signal carries the role " +
                                (r < kNumCanIn ? CanInName(static_cast<CanIn>(r))
                                               : CanOutName(static_cast<CanOut>(r - kNumCanIn))));
        }
      }
      const auto& layout = m.signals[static_cast<std::size_t>(si)].layout;
      if (key == "counter") {
        if (layout.length > 8 || layout.is_signed) {
          return c.Fail(&v, full + ": a counter is an unsigned signal of at most 8 bits");
        }
        spec.counter = si;
      } else {
        if (layout.length != 8 || layout.is_signed || layout.factor != 1.0 ||
            layout.offset != 0.0) {
          return c.Fail(&v,
                        full + ": a checksum is an unsigned 8-bit signal with factor 1, offset 0");
        }
        spec.checksum = si;
      }
    } else if (key == "checksum_kind") {
      const auto s = v.value<std::string>();
      if (s && *s == "crc8") {
        spec.checksum_kind = ChecksumKind::kCrc8;
      } else if (s && *s == "sum8") {
        spec.checksum_kind = ChecksumKind::kSum8;
      } else if (s && *s == "none") {
        spec.checksum_kind = ChecksumKind::kNone;
      } else {
        return c.Fail(&v, full + ": expected \"crc8\", \"sum8\" or \"none\"");
      }
    } else if (key == "crc_poly") {
      if (!Byte(c, v, full, &spec.crc_poly)) return false;
    } else if (key == "crc_init") {
      if (!Byte(c, v, full, &spec.crc_init)) return false;
    } else if (key == "crc_xor") {
      if (!Byte(c, v, full, &spec.crc_xor)) return false;
    } else if (key == "checksum_covers_id") {
      const auto b = v.value<bool>();
      if (!b) return c.Fail(&v, full + ": expected true or false");
      spec.checksum_covers_id = *b;
    } else if (key == "period_ms") {
      if (!Millis(c, v, full, 0.1, 60000.0, &spec.period_ns)) return false;
    } else if (key == "timeout_ms") {
      if (!Millis(c, v, full, 0.1, 60000.0, &spec.timeout_ns)) return false;
    } else {
      return c.Fail(&v, full +
                            ": unknown key (counter, checksum, checksum_kind, crc_poly, "
                            "crc_init, crc_xor, checksum_covers_id, period_ms, timeout_ms)");
    }
  }
  if ((spec.checksum >= 0) != (spec.checksum_kind != ChecksumKind::kNone)) {
    return c.Fail(&t, at + ": checksum and checksum_kind go together (a checksum signal needs "
                           "checksum_kind crc8 or sum8, and the other way round)");
  }
  return true;
}

// What the command signal can carry (its field through factor and offset, within the DBC's
// [min|max] when it gives one) against [command], and the safe state proved (command_section).
bool CheckSetpointSignal(const ProfileContext& c, const toml::table& root, const CanProfile& p) {
  const SignalRef ref = p.outputs[static_cast<std::size_t>(CanOut::kCommand)];
  if (!ref.mapped()) return true;  // the set-point goes elsewhere (a [pwm] output)
  const DbcMessage& msg = p.dbc.messages[static_cast<std::size_t>(ref.message)];
  const DbcSignal& sig = msg.signals[static_cast<std::size_t>(ref.signal)];
  const protocol::SignalLayout& l = sig.layout;
  const double raw_lo = l.is_signed ? -std::ldexp(1.0, l.length - 1) : 0.0;
  const double raw_hi =
      l.is_signed ? std::ldexp(1.0, l.length - 1) - 1 : std::ldexp(1.0, l.length) - 1;
  const double a = raw_lo * l.factor + l.offset, b = raw_hi * l.factor + l.offset;
  SetpointCarrier carrier;
  carrier.name =
      msg.name + "." + sig.name + " (" + p.dbc.path + ":" + std::to_string(sig.line) + ")";
  carrier.lo = std::min(a, b);
  carrier.hi = std::max(a, b);
  if (l.min != 0.0 || l.max != 0.0) {  // the DBC's range: a receiver refuses beyond it
    carrier.lo = std::max(carrier.lo, l.min);
    carrier.hi = std::min(carrier.hi, l.max);
  }
  carrier.step = std::fabs(l.factor);
  return CheckCommandCarrierAt(c, root, p.command, p.command_unit, carrier, "outputs.command");
}

// fault_reset: a bit (unsigned, 1 bit, factor 1, offset 0) of a message the firmware sends
// every control period, i.e. one carrying a command role.
bool CheckFaultResetSignal(const ProfileContext& c, const toml::table& root, const CanProfile& p) {
  const SignalRef ref = p.outputs[static_cast<std::size_t>(CanOut::kFaultReset)];
  if (!ref.mapped()) return true;
  const toml::node* at = root.at_path("outputs.fault_reset").node();
  // The firmware resets only a fault the driver reports: without driver_faults it never edges.
  if (!p.inputs[static_cast<std::size_t>(CanIn::kDriverFaults)].mapped()) {
    return c.Fail(at,
                  "outputs.fault_reset: the profile maps no driver_faults input (the reset "
                  "edges only while the driver reports a fault)");
  }
  const protocol::SignalLayout& l = p.Layout(ref);
  if (l.length != 1 || l.is_signed || l.factor != 1.0 || l.offset != 0.0) {
    return c.Fail(at,
                  "outputs.fault_reset: expected a bit (an unsigned 1-bit signal with factor "
                  "1, offset 0); " +
                      std::to_string(l.length) + " bits");
  }
  for (const CanOut r :
       {CanOut::kCommand, CanOut::kEnable, CanOut::kEnableValid, CanOut::kSafe, CanOut::kEcho}) {
    if (p.outputs[static_cast<std::size_t>(r)].message == ref.message) return true;
  }
  return c.Fail(at, "outputs.fault_reset: message " +
                        p.dbc.messages[static_cast<std::size_t>(ref.message)].name +
                        " is not a command frame the firmware sends every period (map "
                        "command, enable, enable_valid, safe or echo to it)");
}

}  // namespace

const char* CanInName(CanIn role) { return kCanInNames[static_cast<std::size_t>(role)]; }
const char* const* CanInNames() { return kCanInNames; }
const char* CanOutName(CanOut role) { return kCanOutNames[static_cast<std::size_t>(role)]; }

std::uint8_t FrameChecksum(const MessageSpec& spec, const protocol::SignalLayout& checksum,
                           std::uint32_t id, const std::uint8_t* data, int dlc) {
  std::uint64_t skip = 0;
  (void)protocol::SignalMask(checksum, &skip);
  std::uint8_t acc = spec.checksum_kind == ChecksumKind::kCrc8 ? spec.crc_init : 0;
  const auto feed = [&](std::uint8_t byte) {
    if (spec.checksum_kind == ChecksumKind::kSum8) {
      acc = static_cast<std::uint8_t>(acc + byte);
      return;
    }
    acc ^= byte;
    for (int i = 0; i < 8; ++i) {
      acc = (acc & 0x80U) != 0 ? static_cast<std::uint8_t>((acc << 1) ^ spec.crc_poly)
                               : static_cast<std::uint8_t>(acc << 1);
    }
  };
  if (spec.checksum_covers_id) {
    const int id_bytes = id > 0x7FFU ? 4 : 2;
    for (int i = 0; i < id_bytes; ++i) feed(static_cast<std::uint8_t>((id >> (8 * i)) & 0xFFU));
  }
  for (int i = 0; i < dlc && i < 8; ++i) {
    if (((skip >> (8 * i)) & 0xFFU) != 0) continue;  // a byte of the checksum itself
    feed(data[i]);
  }
  return spec.checksum_kind == ChecksumKind::kCrc8 ? static_cast<std::uint8_t>(acc ^ spec.crc_xor)
                                                   : acc;
}

bool LoadCanProfile(const std::string& path, CanProfile* out, std::string* error) {
  std::string text;
  if (!ReadTextFile(path, 1u << 20, &text, error)) return false;
  return ParseCanProfile(text, path, nullptr, out, error);
}

bool ParseCanProfile(const std::string& text, const std::string& path, const std::string* dbc_text,
                     CanProfile* out, std::string* error) {
  *out = CanProfile{};
  out->path = path;
  const ProfileContext c{path, error};
  toml::table root;
  if (!ParseProfileToml(text, path, &root, error)) return false;
  try {
    // The DBC first: every other key refers to it.
    const toml::node* dbc_node = root.get("dbc");
    if (dbc_node == nullptr || !dbc_node->is_string()) {
      *error = path +
               ":1: dbc: expected the DBC file of the driver (a path, relative to the "
               "profile)";
      return false;
    }
    std::string dbc_path = *dbc_node->value<std::string>();
    if (dbc_text != nullptr) {
      if (!ParseDbc(*dbc_text, dbc_path, &out->dbc, error)) return false;
    } else {
      if (dbc_path.empty() || dbc_path[0] != '/')
        dbc_path = ProfileDirectory(path) + "/" + dbc_path;
      if (!LoadDbc(dbc_path, &out->dbc, error)) return false;
    }
    if (out->dbc.messages.size() > 64) {
      *error = dbc_path + ": " + std::to_string(out->dbc.messages.size()) +
               " messages; a profile's DBC may hold at most 64";
      return false;
    }
    out->specs.resize(out->dbc.messages.size());
    for (std::size_t m = 0; m < out->specs.size(); ++m) {
      out->specs[m].message = static_cast<int>(m);
      out->specs[m].period_ns = std::int64_t{out->dbc.messages[m].cycle_time_ms} * 1'000'000;
    }
    std::map<std::pair<int, int>, std::string> owner;  // signal -> the role carrying it
    const auto role_table = [&](const char* section, const char* const* names, std::size_t count,
                                SignalRef* refs, bool transmit) {
      const toml::node* node = root.get(section);
      if (node == nullptr) return true;
      const toml::table* t = node->as_table();
      if (t == nullptr) return c.Fail(node, std::string(section) + ": expected a table");
      for (const auto& [k, v] : *t) {
        const std::string key(k.str());
        std::size_t r = 0;
        while (r < count && key != names[r]) ++r;
        if (r == count) {
          std::string known;
          for (std::size_t i = 0; i < count; ++i) known += (i ? ", " : "") + std::string(names[i]);
          return c.Fail(&v, std::string(section) + "." + key + ": unknown role (" + known + ")");
        }
        const std::string full = std::string(section) + "." + key;
        if (!Resolve(c, v, full, out->dbc, &refs[r])) return false;
        const auto sig = std::make_pair(refs[r].message, refs[r].signal);
        if (const auto it = owner.find(sig); it != owner.end()) {
          return c.Fail(&v, full + ": the signal already carries " + it->second);
        }
        owner[sig] = full;
        MessageSpec& spec = out->specs[static_cast<std::size_t>(refs[r].message)];
        (transmit ? spec.transmit : spec.receive) = true;
        if (spec.transmit && spec.receive) {
          return c.Fail(&v, full + ": message " +
                                out->dbc.messages[static_cast<std::size_t>(refs[r].message)].name +
                                " would be both sent and received by the firmware");
        }
      }
      return true;
    };
    if (!role_table("inputs", kCanInNames, kNumCanIn, out->inputs.data(), false)) return false;
    if (!role_table("outputs", kCanOutNames, kNumCanOut, out->outputs.data(), true)) return false;
    for (const auto& [k, v] : root) {
      const std::string key(k.str());
      if (key == "name") {
        const auto s = v.value<std::string>();
        if (!s || s->empty()) return c.Fail(&v, "name: expected a non-empty string");
        out->name = *s;
      } else if (key == "messages") {
        const toml::table* t = v.as_table();
        if (t == nullptr) return c.Fail(&v, "messages: expected a table of messages");
        for (const auto& [mk, mv] : *t) {
          const toml::table* mt = mv.as_table();
          if (mt == nullptr)
            return c.Fail(&mv, "messages." + std::string(mk.str()) + ": expected a table");
          if (!Message(c, *mt, std::string(mk.str()), out)) return false;
        }
      } else if (key == "command") {
        const toml::table* t = v.as_table();
        if (t == nullptr) return c.Fail(&v, "command: expected a table");
        // [command]: unit, calibration (a CSV relative to the profile), min, max, slew_per_s.
        const std::string dir = dbc_text != nullptr ? std::string(".") : ProfileDirectory(path);
        if (!ReadCommand(c, *t, dir, &out->command_unit, &out->command)) return false;
      } else if (key == "canopen") {
        const toml::table* t = v.as_table();
        if (t == nullptr) return c.Fail(&v, "canopen: expected a table");
        if (!ParseCanopenSection(*t, path, out, error)) return false;
      } else if (key != "dbc" && key != "inputs" && key != "outputs" && key != "description" &&
                 key != "pwm") {  // [pwm]: the PWM output's part (pwm_profile.cpp)
        return c.Fail(&v, key +
                              ": unknown key (name, description, dbc, inputs, outputs, "
                              "messages, command, canopen, pwm)");
      }
    }
    if (out->name.empty()) {
      *error = path + ":1: name: missing (the profile's name, shown in logs and summaries)";
      return false;
    }
    if (!CheckSetpointSignal(c, root, *out)) return false;
    if (!CheckFaultResetSignal(c, root, *out)) return false;
    out->digest = TextDigest(text, out->dbc.digest ^ out->command.digest());
  } catch (const std::exception& e) {
    *error = path + ": " + e.what();
    return false;
  }
  return true;
}

}  // namespace mrd::profile
