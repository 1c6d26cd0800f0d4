#pragma once
// The server side of the register map (docs/modbus_registers.md, "Server conventions"): one
// request PDU answered against the kMapSize holding registers. The server implements 0x03
// and 0x10 only; the exception codes follow the Modbus Application Protocol's order of
// checks (function, then quantity, then address, then value):
//   any other function                               0x01 ILLEGAL FUNCTION
//   a quantity outside 1..125 (0x03) / 1..123 (0x10),
//   a byte count or PDU length that does not match   0x03 ILLEGAL DATA VALUE
//   registers beyond kMapSize - 1                    0x02 ILLEGAL DATA ADDRESS
//   a write touching the read-only sensor block      0x02 ILLEGAL DATA ADDRESS
//   a command block with undefined codes             0x03 ILLEGAL DATA VALUE (block unchanged)
// Unit ids and broadcasts are the transport's business (the caller). Pure code: no I/O, no
// allocation.

#include <cstdint>

#include "mrd/protocol/modbus_frame.hpp"
#include "mrd/protocol/modbus_map.hpp"

namespace mrd::protocol::modbus {

struct ServerAnswer {
  int reply_len = 0;       // bytes of the reply PDU written to *reply (always > 0)
  bool exception = false;  // the reply is an exception (the request was refused)
  bool wrote = false;      // a write was carried out: regs holds the new values
  bool command = false;    // ... and it touched the command block (kCommandBase..+kCommandCount)
};

// regs: the server's registers (a consistent copy; a write updates it in place). reply: room
// for kMaxPdu bytes.
ServerAnswer AnswerRequest(const std::uint8_t* pdu, int len, std::uint16_t regs[kMapSize],
                           std::uint8_t* reply);

}  // namespace mrd::protocol::modbus
