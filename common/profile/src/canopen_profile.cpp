// The [canopen] section of a CAN device profile (canopen_profile.hpp). toml++ reports errors
// by exception: this file is compiled with exceptions; its caller catches them.
#include "mrd/profile/canopen_profile.hpp"

#include <cstdio>
#include <set>
#include <utility>

#include "canopen_section.hpp"
#include "mrd/profile/canopen_codec.hpp"
#include "profile_context.hpp"

namespace mrd::profile {
namespace {

bool Integer(const ProfileContext& c, const toml::node& n, const std::string& key, std::int64_t lo,
             std::int64_t hi, std::int64_t* out) {
  const auto v = n.value_exact<std::int64_t>();
  if (!v || *v < lo || *v > hi) {
    return c.Fail(
        n, key + ": expected an integer in " + std::to_string(lo) + ".." + std::to_string(hi));
  }
  *out = *v;
  return true;
}

bool Node(const ProfileContext& c, const toml::node& n, const std::string& key, int* out) {
  std::int64_t v = 0;
  if (!Integer(c, n, key, 1, 127, &v)) return false;
  *out = static_cast<int>(v);
  return true;
}

// One [[canopen.sdo]] entry.
bool Sdo(const ProfileContext& c, const toml::table& t, SdoDownload* s) {
  s->line = static_cast<int>(t.source().begin.line);
  bool has_index = false, has_value = false;
  std::int64_t v = 0;
  for (const auto& [k, n] : t) {
    const std::string key(k.str());
    const std::string full = "canopen.sdo." + key;
    if (key == "name") {
      const auto str = n.value_exact<std::string>();
      if (!str || str->empty() || str->size() > 80) {
        return c.Fail(n, full + ": expected a short non-empty string");
      }
      s->name = *str;
    } else if (key == "index") {
      if (!Integer(c, n, full, 0x1000, 0xFFFF, &v)) return false;
      s->index = static_cast<std::uint16_t>(v);
      has_index = true;
    } else if (key == "subindex") {
      if (!Integer(c, n, full, 0, 255, &v)) return false;
      s->subindex = static_cast<std::uint8_t>(v);
    } else if (key == "size") {
      if (!Integer(c, n, full, 1, 4, &v) || v == 3) {
        return c.Fail(n, full + ": expected 1, 2 or 4 (bytes)");
      }
      s->size = static_cast<int>(v);
    } else if (key == "value") {
      const auto val = n.value_exact<std::int64_t>();
      if (!val) return c.Fail(n, full + ": expected an integer");
      s->value = *val;
      has_value = true;
    } else {
      return c.Fail(n, full + ": unknown key (name, index, subindex, size, value)");
    }
  }
  if (s->name.empty()) return c.Fail(t, "canopen.sdo: missing 'name' (shown in errors)");
  if (!has_index) return c.Fail(t, "canopen.sdo '" + s->name + "': missing 'index'");
  if (!has_value) return c.Fail(t, "canopen.sdo '" + s->name + "': missing 'value'");
  // A value of `size` bytes: signed or unsigned, e.g. 1 byte -128..255.
  const int bits = 8 * s->size;
  const std::int64_t lo = -(std::int64_t{1} << (bits - 1));
  const std::int64_t hi = (std::int64_t{1} << bits) - 1;
  if (s->value < lo || s->value > hi) {
    const toml::node* at = t.get("value");
    return c.Fail(*at, "canopen.sdo '" + s->name + "': value " + std::to_string(s->value) +
                           " does not fit " + std::to_string(s->size) + " byte(s) (" +
                           std::to_string(lo) + ".." + std::to_string(hi) + ")");
  }
  return true;
}

// A message the profile uses whose standard id is a CANopen COB-ID of the drive or the
// firmware: false with *error at the DBC's line.
bool CheckCollisions(const CanopenConfig& co, const CanProfile& p, std::string* error) {
  struct Reserved {
    std::uint32_t id;
    std::string what;
  };
  const std::string drive = "node " + std::to_string(co.node_id) + " ([canopen] node_id)";
  const std::string own = "node " + std::to_string(co.own_node_id) + " ([canopen] own_node_id)";
  const Reserved reserved[] = {
      {canopen::kNmtId, "the NMT COB-ID"},
      {canopen::kSyncId, "the SYNC COB-ID"},
      {canopen::EmcyId(co.node_id), "the EMCY COB-ID of " + drive},
      {canopen::SdoResponseId(co.node_id), "the SDO response COB-ID of " + drive},
      {canopen::SdoRequestId(co.node_id), "the SDO request COB-ID of " + drive},
      {canopen::HeartbeatId(co.node_id), "the heartbeat COB-ID of " + drive},
      {canopen::HeartbeatId(co.own_node_id), "the heartbeat COB-ID of " + own},
  };
  for (std::size_t m = 0; m < p.dbc.messages.size(); ++m) {
    const DbcMessage& msg = p.dbc.messages[m];
    if (msg.extended || (!p.specs[m].transmit && !p.specs[m].receive)) continue;
    for (const Reserved& r : reserved) {
      if (msg.id != r.id) continue;
      char id[16];
      std::snprintf(id, sizeof id, "0x%03X", static_cast<unsigned>(msg.id));
      *error = p.dbc.path + ":" + std::to_string(msg.line) + ": message " + msg.name + " (" + id +
               ") collides with " + r.what;
      return false;
    }
  }
  return true;
}

}  // namespace

std::string DescribeSdo(const SdoDownload& sdo) {
  char at[32];
  std::snprintf(at, sizeof at, "0x%04X:%02X", static_cast<unsigned>(sdo.index),
                static_cast<unsigned>(sdo.subindex));
  return "'" + sdo.name + "' " + at + " = " + std::to_string(sdo.value);
}

std::string SdoRefusalMessage(const SdoDownload& sdo, std::uint32_t abort_code) {
  char code[16];
  std::snprintf(code, sizeof code, "0x%08X", static_cast<unsigned>(abort_code));
  return "drive refused SDO " + DescribeSdo(sdo) + ": abort " + code + " " +
         canopen::SdoAbortText(abort_code);
}

bool ParseCanopenSection(const toml::table& t, const std::string& path, CanProfile* p,
                         std::string* error) {
  const ProfileContext c{path, error};
  CanopenConfig co;
  bool has_node = false, has_own = false;
  std::int64_t v = 0;
  for (const auto& [k, n] : t) {
    const std::string key(k.str());
    const std::string full = "canopen." + key;
    if (key == "node_id") {
      if (!Node(c, n, full, &co.node_id)) return false;
      has_node = true;
    } else if (key == "own_node_id") {
      if (!Node(c, n, full, &co.own_node_id)) return false;
      has_own = true;
    } else if (key == "heartbeat_ms") {
      // CiA 301 producer heartbeat time (0x1017): UNSIGNED16 ms.
      if (!Integer(c, n, full, 0, 65535, &v)) return false;
      co.heartbeat_ns = v * 1'000'000;
    } else if (key == "drive_heartbeat_timeout_ms") {
      if (!Integer(c, n, full, 0, 65535, &v)) return false;
      co.drive_heartbeat_timeout_ns = v * 1'000'000;
    } else if (key == "nmt_start") {
      const auto b = n.value_exact<bool>();
      if (!b) return c.Fail(n, full + ": expected true or false");
      co.nmt_start = *b;
    } else if (key == "sync_period_ms") {
      if (!Integer(c, n, full, 0, 10000, &v)) return false;
      co.sync_period_ns = v * 1'000'000;
    } else if (key == "sdo_timeout_ms") {
      if (!Integer(c, n, full, 1, 60000, &v)) return false;
      co.sdo_timeout_ns = v * 1'000'000;
    } else if (key == "sdo") {
      const toml::array* a = n.as_array();
      if (a == nullptr) return c.Fail(n, full + ": expected an array of tables ([[canopen.sdo]])");
      std::set<std::string> names;
      std::set<std::pair<int, int>> objects;
      for (const toml::node& e : *a) {
        const toml::table* et = e.as_table();
        if (et == nullptr)
          return c.Fail(e, full + ": each entry must be a table ([[canopen.sdo]])");
        SdoDownload s;
        if (!Sdo(c, *et, &s)) return false;
        if (!names.insert(s.name).second) {
          return c.Fail(e, "canopen.sdo '" + s.name + "': duplicate name");
        }
        if (!objects.insert({s.index, s.subindex}).second) {
          char at[32];
          std::snprintf(at, sizeof at, "0x%04X:%02X", static_cast<unsigned>(s.index),
                        static_cast<unsigned>(s.subindex));
          return c.Fail(e, "canopen.sdo '" + s.name + "': duplicate object " + at +
                               " (written by an earlier entry)");
        }
        co.sdo.push_back(std::move(s));
      }
    } else {
      return c.Fail(n, full +
                           ": unknown key (node_id, own_node_id, heartbeat_ms, "
                           "drive_heartbeat_timeout_ms, nmt_start, sync_period_ms, "
                           "sdo_timeout_ms, sdo)");
    }
  }
  if (!has_node) return c.Fail(t, "canopen.node_id: missing (the drive's node id, 1..127)");
  if (!has_own) {
    return c.Fail(t, "canopen.own_node_id: missing (the firmware's node id, 1..127)");
  }
  if (co.node_id == co.own_node_id) {
    return c.Fail(*t.get("own_node_id"), "canopen.own_node_id: equals node_id " +
                                             std::to_string(co.node_id) +
                                             " (the firmware and the drive need their own ids)");
  }
  if (!CheckCollisions(co, *p, error)) return false;
  p->canopen = std::move(co);
  return true;
}

}  // namespace mrd::profile
