#pragma once
// A small parser of the DBC subset a device profile needs (docs/devices.md, "DBC subset"):
//   BO_ <id> <Name>: <dlc> <transmitter>          a message; id bit 31 set = 29-bit extended
//    SG_ <Name> : <start>|<len>@<0|1><+|-> (<factor>,<offset>) [<min>|<max>] "<unit>" <rx>
//   BA_ "GenMsgCycleTime" BO_ <id> <ms>;          the message's transmit period
// Everything else of the format (VERSION, NS_, BS_, BU_, CM_, BA_DEF_, BA_DEF_DEF_, other BA_,
// VAL_, VAL_TABLE_, BO_TX_BU_, EV_) is read over; multiplexed signals (M, mN) and
// SIG_VALTYPE_ (float signals) are refused. Configuration-time code: allocates, no exceptions.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "mrd/protocol/can_signal.hpp"

namespace mrd::profile {

struct DbcSignal {
  std::string name;
  protocol::SignalLayout layout;
  std::string unit;
  int line = 0;  // where it was defined
};

struct DbcMessage {
  std::string name;
  std::uint32_t id = 0;   // 11-bit or 29-bit identifier (without the DBC's bit 31)
  bool extended = false;  // 29-bit identifier
  int dlc = 8;
  int cycle_time_ms = 0;  // GenMsgCycleTime; 0 = not given
  std::vector<DbcSignal> signals;
  int line = 0;
  const DbcSignal* Find(std::string_view signal) const;
};

struct Dbc {
  std::string path;
  std::uint64_t digest = 0;  // of the text parsed (a reload notices a changed file)
  std::vector<DbcMessage> messages;
  const DbcMessage* Find(std::string_view message) const;
};

// Parses DBC text; `path` names it in errors. On failure *error is "PATH:LINE: reason" and
// false is returned. Checks: every number in range, dlc 0..8, signal length 1..64 bits, factor
// != 0, min <= max, every signal inside its message, no two signals of a message sharing a
// bit, no duplicate message name or identifier, no duplicate signal name in a message.
bool ParseDbc(std::string_view text, const std::string& path, Dbc* out, std::string* error);
// Reads and parses a file (regular files only, at most 4 MiB).
bool LoadDbc(const std::string& path, Dbc* out, std::string* error);

}  // namespace mrd::profile
