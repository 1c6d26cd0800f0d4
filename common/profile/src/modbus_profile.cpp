// Loading a Modbus device profile (modbus_profile.hpp) and grouping its requests. toml++
// reports errors by exception: this file alone is compiled with exceptions and catches them.
#include "mrd/profile/modbus_profile.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <map>
#include <tuple>
#include <utility>
#include <vector>

#include "command_section.hpp"
#include "file_text.hpp"
#include "mrd/profile/modbus_channels.hpp"
#include "profile_context.hpp"

namespace mrd::profile {
namespace {

constexpr const char* kOutNames[kNumModbusOut] = {"command",
                                                  "enable",
                                                  "safe",
                                                  "echo",
                                                  "heartbeat",
                                                  "status_safe",
                                                  "status_causes",
                                                  "status_overruns",
                                                  "status_safe_entries",
                                                  "status_model_force",
                                                  "status_demand",
                                                  "status_command",
                                                  "fault_reset"};

constexpr int kMaxReadRegisters = 125;   // 0x03 / 0x04
constexpr int kMaxReadBits = 2000;       // 0x01 / 0x02
constexpr int kMaxWriteRegisters = 123;  // 0x10
constexpr int kMaxWriteBits = 1968;      // 0x0F

bool IsBit(ModbusTable t) { return t == ModbusTable::kCoil || t == ModbusTable::kDiscrete; }

std::uint8_t ReadFunction(ModbusTable t) {
  switch (t) {
    case ModbusTable::kCoil:
      return 0x01;
    case ModbusTable::kDiscrete:
      return 0x02;
    case ModbusTable::kHolding:
      return 0x03;
    case ModbusTable::kInput:
      return 0x04;
  }
  return 0x03;
}

// One role's inline table: { unit, table, address, type, scale, offset, word_order }.
bool Point(const ProfileContext& c, const toml::node& n, const std::string& full, bool output,
           bool swapped, ModbusPoint* pt) {
  const toml::table* t = n.as_table();
  if (t == nullptr) {
    return c.Fail(&n, full + ": expected { unit = ..., table = ..., address = ..., type = ... }");
  }
  *pt = ModbusPoint{};
  pt->mapped = true;
  pt->swapped = swapped;  // the profile's word order unless the point gives its own
  const toml::node* order_node = nullptr;
  pt->line = static_cast<int>(n.source().begin.line);
  bool have_unit = false, have_table = false, have_address = false;
  const toml::node* type_node = nullptr;
  for (const auto& [k, v] : *t) {
    const std::string key(k.str());
    const std::string at = full + "." + key;
    if (key == "unit") {
      const auto u = v.value<std::int64_t>();
      if (!u || *u < 1 || *u > 247) return c.Fail(&v, at + ": unit id outside 1..247");
      pt->unit = static_cast<std::uint8_t>(*u);
      have_unit = true;
    } else if (key == "table") {
      const auto s = v.value<std::string>();
      if (s && *s == "holding") {
        pt->table = ModbusTable::kHolding;
      } else if (s && *s == "input") {
        pt->table = ModbusTable::kInput;
      } else if (s && *s == "coil") {
        pt->table = ModbusTable::kCoil;
      } else if (s && *s == "discrete") {
        pt->table = ModbusTable::kDiscrete;
      } else {
        return c.Fail(&v, at + ": unknown table (holding, input, coil, discrete)");
      }
      have_table = true;
    } else if (key == "address") {
      const auto a = v.value<std::int64_t>();
      if (!a || *a < 0 || *a > 65535) return c.Fail(&v, at + ": address outside 0..65535");
      pt->address = static_cast<int>(*a);
      have_address = true;
    } else if (key == "type") {
      const auto s = v.value<std::string>();
      static const std::pair<const char*, ModbusType> kTypes[] = {
          {"int16", ModbusType::kInt16},
          {"uint16", ModbusType::kUint16},
          {"int32", ModbusType::kInt32},
          {"uint32", ModbusType::kUint32},
          {"float32", ModbusType::kFloat32}};
      bool found = false;
      for (const auto& [name, type] : kTypes) {
        if (s && *s == name) {
          pt->type = type;
          found = true;
        }
      }
      if (!found) return c.Fail(&v, at + ": unknown type (int16, uint16, int32, uint32, float32)");
      type_node = &v;
    } else if (key == "scale" || key == "offset") {
      const auto d = v.value<double>();
      if (!d || !std::isfinite(*d) || (key == "scale" && *d == 0.0)) {
        return c.Fail(&v, at + (key == "scale" ? ": expected a finite non-zero number"
                                               : ": expected a finite number"));
      }
      (key == "scale" ? pt->scale : pt->offset) = *d;
    } else if (key == "word_order") {
      const auto s = v.value<std::string>();
      if (!s || (*s != "big" && *s != "swapped")) {
        return c.Fail(&v, at + ": expected \"big\" (high word first) or \"swapped\"");
      }
      pt->swapped = *s == "swapped";
      order_node = &v;
    } else {
      return c.Fail(&v, at + ": unknown key (unit, table, address, type, scale, offset, "
                             "word_order)");
    }
  }
  if (!have_unit || !have_table || !have_address) {
    return c.Fail(&n, full + ": needs unit, table and address");
  }
  if (IsBit(pt->table)) {
    if (type_node != nullptr) {
      return c.Fail(type_node, full + ": a coil or discrete input is one bit: no type");
    }
    pt->type = ModbusType::kBit;
  }
  if (order_node != nullptr && pt->count() != 2) {
    return c.Fail(order_node, full + ": word_order is for 32-bit values (int32, uint32, float32)");
  }
  if (output && (pt->table == ModbusTable::kInput || pt->table == ModbusTable::kDiscrete)) {
    return c.Fail(&n, full + ": an output goes to a writable table (holding, coil)");
  }
  if (pt->address + pt->count() - 1 > 65535) {
    return c.Fail(&n, full + ": address " + std::to_string(pt->address) + " + " +
                          std::to_string(pt->count()) + " registers goes beyond 65535");
  }
  return true;
}

// Greedy left-to-right grouping (optimal for intervals on a line under a length cap): sorted
// points of one unit and table join the open request while the gap to its end is at most
// max_gap and the request stays within cap.
void GroupPoints(std::vector<ModbusPoint*> sorted, int max_gap, int cap_registers, int cap_bits,
                 bool single, bool writes, std::vector<ModbusRequest>* out) {
  std::sort(sorted.begin(), sorted.end(), [](const ModbusPoint* a, const ModbusPoint* b) {
    return std::tie(a->unit, a->table, a->address) < std::tie(b->unit, b->table, b->address);
  });
  for (ModbusPoint* pt : sorted) {
    const int cap = IsBit(pt->table) ? cap_bits : cap_registers;
    ModbusRequest* open = out->empty() ? nullptr : &out->back();
    if (open != nullptr && !single && open->unit == pt->unit && open->table == pt->table) {
      const int end = open->address + open->count;
      const int new_count = pt->address + pt->count() - open->address;
      if (pt->address - end <= max_gap && new_count <= cap) {
        pt->request = static_cast<int>(out->size()) - 1;
        pt->index = pt->address - open->address;
        open->count = std::max(open->count, new_count);
        continue;
      }
    }
    ModbusRequest r;
    r.unit = pt->unit;
    r.table = pt->table;
    r.address = pt->address;
    r.count = pt->count();
    r.function = !writes            ? ReadFunction(pt->table)
                 : IsBit(pt->table) ? (single ? 0x05 : 0x0F)
                                    : (single ? 0x06 : 0x10);
    pt->request = static_cast<int>(out->size());
    pt->index = 0;
    out->push_back(r);
  }
}

template <std::size_t N>
void Group(std::array<ModbusPoint, N>& points, int max_gap, int cap_registers, int cap_bits,
           bool single, bool writes, std::vector<ModbusRequest>* out) {
  std::vector<ModbusPoint*> sorted;
  for (auto& pt : points) {
    if (pt.mapped) sorted.push_back(&pt);
  }
  GroupPoints(std::move(sorted), max_gap, cap_registers, cap_bits, single, writes, out);
}

}  // namespace

bool LoadModbusProfile(const std::string& path, ModbusProfile* out, std::string* error) {
  std::string text;
  if (!ReadTextFile(path, 1u << 20, &text, error)) return false;
  return ParseModbusProfile(text, path, out, error);
}

bool IsModbusProfileFile(const std::string& path) {
  std::string text, error;
  if (!ReadTextFile(path, 1u << 20, &text, &error)) return false;
  try {
    const toml::table root = toml::parse(text, path);
    return root.get("modbus") != nullptr;
  } catch (const std::exception&) {
    return false;
  }
}

namespace {

// Top-level keys (name, description, command; [modbus] is read by ReadModbusKeys).
bool ReadTopLevel(const ProfileContext& c, const toml::table& root, const std::string& path,
                  ModbusProfile* out) {
  for (const auto& [k, v] : root) {
    const std::string key(k.str());
    if (key == "name") {
      const auto s = v.value<std::string>();
      if (!s || s->empty()) return c.Fail(&v, "name: expected a non-empty string");
      out->name = *s;
    } else if (key == "description") {
      if (!v.is_string()) return c.Fail(&v, "description: expected a string");
    } else if (key == "command") {
      const toml::table* t = v.as_table();
      if (t == nullptr) return c.Fail(&v, "command: expected a table");
      // [command]: unit, calibration (a CSV relative to the profile), min, max, slew_per_s.
      if (!ReadCommand(c, *t, ProfileDirectory(path), &out->command_unit, &out->command)) {
        return false;
      }
    } else if (key != "modbus") {
      return c.Fail(&v, key + ": unknown key (name, description, modbus, command)");
    }
  }
  if (out->name.empty()) {
    *c.error = path + ":1: name: missing (the profile's name, shown in logs and summaries)";
    return false;
  }
  return true;
}

// The [modbus] table's own keys (the inputs and outputs tables: ReadRoles).
bool ReadModbusKeys(const ProfileContext& c, const toml::table& modbus, ModbusProfile* out) {
  for (const auto& [k, v] : modbus) {
    const std::string key(k.str());
    const std::string full = "modbus." + key;
    if (key == "word_order") {
      const auto s = v.value<std::string>();
      if (s && *s == "big") {
        out->swapped = false;
      } else if (s && *s == "swapped") {
        out->swapped = true;
      } else {
        return c.Fail(&v, full + ": expected \"big\" (high word first) or \"swapped\"");
      }
    } else if (key == "write_function") {
      const auto n = v.value<std::int64_t>();
      if (!n || (*n != 16 && *n != 6)) {
        return c.Fail(&v, full + ": expected 16 (write multiple) or 6 (write single)");
      }
      out->write_function = static_cast<int>(*n);
    } else if (key == "align32") {
      const auto b = v.value<bool>();
      if (!b) return c.Fail(&v, full + ": expected true or false");
      out->align32 = *b;
    } else if (key == "max_read") {
      const auto n = v.value<std::int64_t>();
      if (!n || *n < 1 || *n > kMaxReadRegisters) {
        return c.Fail(&v, full + ": registers per read outside 1..125 (the Modbus limit)");
      }
      out->max_read = static_cast<int>(*n);
    } else if (key == "fault_reset_ms") {
      const auto n = v.value<std::int64_t>();
      if (!n || *n < 100 || *n > 600000) {
        return c.Fail(&v, full + ": expected an integer in 100..600000 [ms]");
      }
      out->fault_reset_ms = static_cast<int>(*n);
    } else if (key != "inputs" && key != "outputs" && key != "startup" && key != "periodic") {
      return c.Fail(&v, full +
                            ": unknown key (word_order, write_function, align32, max_read, "
                            "fault_reset_ms, inputs, outputs, startup, periodic)");
    }
  }
  return true;
}

// Register (bit) of a unit's table -> the role that carries it, for the overlap check.
using RegisterOwners = std::map<std::tuple<int, int, int>, std::string>;

// One roles table (modbus.inputs or modbus.outputs), in file order (toml++ keeps keys sorted):
// an overlap names the later line.
bool ReadRoles(const ProfileContext& c, const toml::table& modbus, const char* section,
               const char* const* names, std::size_t count, ModbusPoint* points, bool output,
               const ModbusProfile& profile, RegisterOwners* owner) {
  const toml::node* node = modbus.get(section);
  if (node == nullptr) return true;
  const toml::table* t = node->as_table();
  const std::string sec = std::string("modbus.") + section;
  if (t == nullptr) return c.Fail(node, sec + ": expected a table");
  std::vector<std::pair<std::string, const toml::node*>> in_order;
  for (const auto& [k, v] : *t) in_order.emplace_back(std::string(k.str()), &v);
  std::stable_sort(in_order.begin(), in_order.end(), [](const auto& a, const auto& b) {
    return a.second->source().begin.line < b.second->source().begin.line;
  });
  for (const auto& [key, vp] : in_order) {
    const toml::node& v = *vp;
    std::size_t r = 0;
    while (r < count && key != names[r]) ++r;
    const std::string full = sec + "." + key;
    if (r == count) {
      std::string known;
      for (std::size_t i = 0; i < count; ++i) known += (i ? ", " : "") + std::string(names[i]);
      return c.Fail(&v, full + ": unknown role (" + known + ")");
    }
    // toml++ refuses a key twice in one table; a role is mapped once by construction.
    ModbusPoint& pt = points[r];
    if (!Point(c, v, full, output, profile.swapped, &pt)) return false;
    if (profile.align32 && pt.count() == 2 && pt.address % 2 != 0) {
      return c.Fail(&v, full + ": 32-bit value at odd address " + std::to_string(pt.address) +
                            " (align32: the device needs even addresses)");
    }
    if (output && pt.count() == 2 && profile.write_function == 6) {
      return c.Fail(&v, full +
                            ": a 32-bit value cannot be written with write_function 6 "
                            "(one register per request); use 16");
    }
    for (int i = 0; i < pt.count(); ++i) {
      const auto at = std::make_tuple(int{pt.unit}, static_cast<int>(pt.table), pt.address + i);
      if (const auto it = owner->find(at); it != owner->end()) {
        return c.Fail(&v, full + ": register " + std::to_string(pt.address + i) + " of unit " +
                              std::to_string(pt.unit) + " already carries " + it->second);
      }
      (*owner)[at] = full;
    }
  }
  return true;
}

// [[modbus.startup]] or [[modbus.periodic]]: fixed writes, each { unit, table, address,
// value } (periodic: period_ms, watchdog_ms), never on a register a role carries.
bool ReadFixedWrites(const ProfileContext& c, const toml::table& modbus, const char* section,
                     const RegisterOwners& owner, std::vector<ModbusFixedWrite>* out) {
  const toml::node* node = modbus.get(section);
  if (node == nullptr) return true;
  const bool periodic = std::string(section) == "periodic";
  const std::string sec = std::string("modbus.") + section;
  const toml::array* arr = node->as_array();
  if (arr == nullptr) return c.Fail(node, sec + ": expected [[" + sec + "]] entries");
  for (const toml::node& n : *arr) {
    const toml::table* t = n.as_table();
    if (t == nullptr) return c.Fail(&n, sec + ": expected { unit, table, address, value }");
    ModbusFixedWrite w;
    w.line = static_cast<int>(n.source().begin.line);
    bool have[4] = {false, false, false, false};  // unit, table, address, value
    const auto integer = [&](const toml::node& v, const std::string& at, std::int64_t lo,
                             std::int64_t hi, std::int64_t* x) {
      const auto i = v.value<std::int64_t>();
      if (!i || *i < lo || *i > hi) {
        return c.Fail(
            &v, at + ": expected an integer in " + std::to_string(lo) + ".." + std::to_string(hi));
      }
      *x = *i;
      return true;
    };
    for (const auto& [k, v] : *t) {
      const std::string key(k.str());
      const std::string at = sec + "." + key;
      std::int64_t x = 0;
      if (key == "unit") {
        if (!integer(v, at, 1, 247, &x)) return false;
        w.unit = static_cast<std::uint8_t>(x);
        have[0] = true;
      } else if (key == "table") {
        const auto s = v.value<std::string>();
        if (s && *s == "holding") {
          w.table = ModbusTable::kHolding;
        } else if (s && *s == "coil") {
          w.table = ModbusTable::kCoil;
        } else {
          return c.Fail(&v, at + ": a fixed write goes to a writable table (holding, coil)");
        }
        have[1] = true;
      } else if (key == "address") {
        if (!integer(v, at, 0, 65535, &x)) return false;
        w.address = static_cast<int>(x);
        have[2] = true;
      } else if (key == "value") {
        if (!integer(v, at, 0, 65535, &x)) return false;
        w.value = static_cast<std::uint16_t>(x);
        have[3] = true;
      } else if (periodic && key == "period_ms") {
        if (!integer(v, at, 1, 60000, &x)) return false;
        w.period_ms = static_cast<int>(x);
      } else if (periodic && key == "watchdog_ms") {
        if (!integer(v, at, 1, 60000, &x)) return false;
        w.watchdog_ms = static_cast<int>(x);
      } else {
        return c.Fail(&v, at + (periodic ? ": unknown key (unit, table, address, value, "
                                           "period_ms, watchdog_ms)"
                                         : ": unknown key (unit, table, address, value)"));
      }
    }
    if (!have[0] || !have[1] || !have[2] || !have[3]) {
      return c.Fail(&n, sec + ": needs unit, table, address and value");
    }
    if (periodic && w.period_ms == 0) return c.Fail(&n, sec + ": needs period_ms");
    if (w.watchdog_ms != 0 && w.watchdog_ms <= w.period_ms) {
      return c.Fail(t->get("watchdog_ms"),
                    sec + ".watchdog_ms: " + std::to_string(w.watchdog_ms) +
                        " ms is not above period_ms (" + std::to_string(w.period_ms) +
                        " ms): the driver would drop its coil between two writes");
    }
    if (w.table == ModbusTable::kCoil && w.value > 1) {
      return c.Fail(t->get("value"), sec + ".value: a coil is 0 or 1");
    }
    const auto at = std::make_tuple(int{w.unit}, static_cast<int>(w.table), w.address);
    if (const auto it = owner.find(at); it != owner.end()) {
      return c.Fail(&n, sec + ": register " + std::to_string(w.address) + " of unit " +
                            std::to_string(w.unit) + " already carries " + it->second);
    }
    out->push_back(w);
  }
  return true;
}

// The request carrying the command goes last (the harness takes it as the cycle's end).
void PutCommandLast(ModbusProfile* out) {
  ModbusPoint& cmd = out->outputs[static_cast<std::size_t>(ModbusOut::kCommand)];
  if (!cmd.mapped || cmd.request == static_cast<int>(out->writes.size()) - 1) return;
  const int from = cmd.request;
  const ModbusRequest moved = out->writes[static_cast<std::size_t>(from)];
  out->writes.erase(out->writes.begin() + from);
  out->writes.push_back(moved);
  for (auto& pt : out->outputs) {
    if (!pt.mapped) continue;
    if (pt.request == from) {
      pt.request = static_cast<int>(out->writes.size()) - 1;
    } else if (pt.request > from) {
      --pt.request;
    }
  }
}

// What the command register can carry (its type through scale and offset) against
// [command], and the safe state proved (command_section).
bool CheckSetpointRegister(const ProfileContext& c, const toml::table& root,
                           const ModbusProfile& p) {
  const ModbusPoint& pt = p.Out(ModbusOut::kCommand);
  if (!pt.mapped) return true;
  double raw_lo = 0.0, raw_hi = 1.0, step = std::fabs(pt.scale);
  switch (pt.type) {
    case ModbusType::kInt16:
      raw_lo = -32768.0;
      raw_hi = 32767.0;
      break;
    case ModbusType::kUint16:
      raw_hi = 65535.0;
      break;
    case ModbusType::kInt32:
      raw_lo = -2147483648.0;
      raw_hi = 2147483647.0;
      break;
    case ModbusType::kUint32:
      raw_hi = 4294967295.0;
      break;
    case ModbusType::kFloat32:
      raw_lo = -static_cast<double>(FLT_MAX);
      raw_hi = static_cast<double>(FLT_MAX);
      step = 0.0;
      break;
    case ModbusType::kBit:
      break;
  }
  const double a = raw_lo * pt.scale + pt.offset, b = raw_hi * pt.scale + pt.offset;
  SetpointCarrier carrier;
  carrier.name =
      std::string("the command register (") + p.path + ":" + std::to_string(pt.line) + ")";
  carrier.lo = std::min(a, b);
  carrier.hi = std::max(a, b);
  carrier.step = step;
  return CheckCommandCarrierAt(c, root, p.command, p.command_unit, carrier,
                               "modbus.outputs.command");
}

}  // namespace

bool ParseModbusProfile(const std::string& text, const std::string& path, ModbusProfile* out,
                        std::string* error) {
  *out = ModbusProfile{};
  out->path = path;
  const ProfileContext c{path, error};
  toml::table root;
  if (!ParseProfileToml(text, path, &root, error)) return false;
  try {
    const toml::node* modbus_node = root.get("modbus");
    const toml::table* modbus = modbus_node != nullptr ? modbus_node->as_table() : nullptr;
    if (modbus == nullptr) {
      return c.Fail(modbus_node, "modbus: expected the [modbus] table of the device's map");
    }
    if (!ReadTopLevel(c, root, path, out) || !ReadModbusKeys(c, *modbus, out)) return false;
    // Roles, then the overlap of every register (bit) of a unit's table.
    RegisterOwners owner;
    if (!ReadRoles(c, *modbus, "inputs", CanInNames(), kNumCanIn, out->inputs.data(), false, *out,
                   &owner) ||
        !ReadRoles(c, *modbus, "outputs", kOutNames, kNumModbusOut, out->outputs.data(), true, *out,
                   &owner)) {
      return false;
    }
    // The firmware resets only a fault the driver reports: without driver_faults it never edges.
    if (out->Out(ModbusOut::kFaultReset).mapped && !out->In(CanIn::kDriverFaults).mapped) {
      return c.Fail(modbus->at_path("outputs.fault_reset").node(),
                    "modbus.outputs.fault_reset: the profile maps no driver_faults input (the "
                    "reset edges only while the driver reports a fault)");
    }
    if (!ReadFixedWrites(c, *modbus, "startup", owner, &out->startup) ||
        !ReadFixedWrites(c, *modbus, "periodic", owner, &out->periodic)) {
      return false;
    }
    const bool single = out->write_function == 6;
    Group(out->inputs, ModbusProfile::kMaxGap, out->max_read, kMaxReadBits, false, false,
          &out->reads);
    Group(out->outputs, 0, kMaxWriteRegisters, kMaxWriteBits, single, true, &out->writes);
    PutCommandLast(out);
    if (!CheckSetpointRegister(c, root, *out)) return false;
    out->digest = TextDigest(text, out->command.digest());
  } catch (const std::exception& e) {
    *error = path + ": " + e.what();
    return false;
  }
  return true;
}

void GroupModbusReads(const std::vector<ModbusPoint*>& points, int max_read,
                      std::vector<ModbusRequest>* out) {
  GroupPoints(points, ModbusProfile::kMaxGap, max_read, kMaxReadBits, false, false, out);
}

}  // namespace mrd::profile
