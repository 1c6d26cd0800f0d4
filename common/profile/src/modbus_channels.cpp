// Several channels' Modbus maps on one link (modbus_channels.hpp): the shared read plan and
// the checks that the maps can share the link.
#include "mrd/profile/modbus_channels.hpp"

#include <algorithm>

namespace mrd::profile {
namespace {

const char* TableName(ModbusTable t) {
  switch (t) {
    case ModbusTable::kCoil:
      return "coil";
    case ModbusTable::kDiscrete:
      return "discrete input";
    case ModbusTable::kHolding:
      return "holding register";
    case ModbusTable::kInput:
      return "input register";
  }
  return "register";
}

// What one channel writes: an output point or a fixed write, as a range of one unit's table.
struct Written {
  std::uint8_t unit = 0;
  ModbusTable table = ModbusTable::kHolding;
  int address = 0, count = 1;
  int line = 0;
  bool fixed = false;
  std::uint16_t value = 0;
};

std::vector<Written> WrittenBy(const ModbusProfile& p) {
  std::vector<Written> w;
  for (const ModbusPoint& pt : p.outputs) {
    if (pt.mapped) w.push_back({pt.unit, pt.table, pt.address, pt.count(), pt.line, false, 0});
  }
  for (const auto* list : {&p.startup, &p.periodic}) {
    for (const ModbusFixedWrite& f : *list) {
      w.push_back({f.unit, f.table, f.address, 1, f.line, true, f.value});
    }
  }
  return w;
}

bool Overlap(const Written& a, const Written& b) {
  return a.unit == b.unit && a.table == b.table && a.address < b.address + b.count &&
         b.address < a.address + a.count;
}

}  // namespace

int ModbusChannelPlan::MaxCount() const {
  int n = 0;
  for (const ModbusRequest& r : reads) n = std::max(n, r.count);
  return n;
}

bool PlanModbusChannels(const std::vector<const ModbusProfile*>& channels, ModbusChannelPlan* out,
                        std::string* error) {
  *out = ModbusChannelPlan{};
  if (channels.empty() || channels.size() > kMaxModbusChannels) {
    *error = "modbus channels: " + std::to_string(channels.size()) + " maps (1.." +
             std::to_string(kMaxModbusChannels) + " share one link)";
    return false;
  }
  const ModbusProfile& first = *channels[0];
  for (std::size_t k = 1; k < channels.size(); ++k) {
    const ModbusProfile& p = *channels[k];
    const char* key = p.swapped != first.swapped                 ? "word_order"
                      : p.write_function != first.write_function ? "write_function"
                      : p.align32 != first.align32               ? "align32"
                      : p.max_read != first.max_read             ? "max_read"
                                                                 : nullptr;
    if (key != nullptr) {
      *error = p.path + ": [modbus] " + key + " differs from channel 0's (" + first.path +
               "): the channels of one link share it";
      return false;
    }
  }
  for (std::size_t a = 0; a < channels.size(); ++a) {
    const std::vector<Written> wa = WrittenBy(*channels[a]);
    for (std::size_t b = a + 1; b < channels.size(); ++b) {
      for (const Written& y : WrittenBy(*channels[b])) {
        for (const Written& x : wa) {
          if (!Overlap(x, y)) continue;
          if (x.fixed && y.fixed && x.address == y.address && x.value == y.value) continue;
          *error = channels[b]->path + ":" + std::to_string(y.line) + ": unit " +
                   std::to_string(y.unit) + " " + TableName(y.table) + " " +
                   std::to_string(y.address) + " is written by channel " + std::to_string(a) +
                   " too (" + channels[a]->path + ":" + std::to_string(x.line) +
                   "): each channel writes its own registers";
          return false;
        }
      }
    }
  }
  out->inputs.resize(channels.size());
  std::vector<ModbusPoint*> points;
  for (std::size_t k = 0; k < channels.size(); ++k) {
    out->inputs[k] = channels[k]->inputs;
    for (ModbusPoint& pt : out->inputs[k]) {
      pt.request = -1;
      if (pt.mapped) points.push_back(&pt);
    }
  }
  GroupModbusReads(points, first.max_read, &out->reads);
  out->served.assign(out->reads.size(), 0U);
  for (std::size_t k = 0; k < channels.size(); ++k) {
    for (const ModbusPoint& pt : out->inputs[k]) {
      if (pt.mapped) out->served[static_cast<std::size_t>(pt.request)] |= 1U << k;
    }
  }
  return true;
}

}  // namespace mrd::profile
