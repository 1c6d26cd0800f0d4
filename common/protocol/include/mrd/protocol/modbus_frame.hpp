#pragma once
// Modbus framing (Modbus Application Protocol V1.1b3, Modbus over serial line V1.02, Modbus
// Messaging on TCP/IP Implementation Guide V1.0b) for the two functions the register map uses
// (0x03 read holding registers, 0x10 write multiple registers): PDUs, the TCP MBAP header,
// the RTU CRC and RTU frame lengths. Shared by the firmware's client and the harness's server
// (docs/modbus_registers.md). Pure code: no I/O, no allocation, no exceptions.
//
// ADUs: TCP = MBAP (transaction id, protocol id 0, length = unit byte + PDU, unit id) + PDU;
// RTU = address + PDU + CRC-16 (low byte first).

#include <cstddef>
#include <cstdint>

namespace mrd::protocol::modbus {

inline constexpr std::uint8_t kFcReadHolding = 0x03;
inline constexpr std::uint8_t kFcWriteMultiple = 0x10;
inline constexpr std::uint8_t kExceptionFlag = 0x80;  // function | 0x80 in an exception reply

// Exception codes (Application Protocol §7).
inline constexpr std::uint8_t kExIllegalFunction = 0x01;
inline constexpr std::uint8_t kExIllegalAddress = 0x02;
inline constexpr std::uint8_t kExIllegalValue = 0x03;
inline constexpr std::uint8_t kExServerFailure = 0x04;
inline constexpr std::uint8_t kExGatewayNoResponse = 0x0B;  // no device with that unit id

inline constexpr std::uint8_t kBroadcastUnit = 0;     // RTU: every server acts, none answers
inline constexpr std::uint8_t kTcpDirectUnit = 0xFF;  // TCP: "no unit", the server addressed by IP

inline constexpr int kMaxReadCount = 125;   // registers per 0x03 request
inline constexpr int kMaxWriteCount = 123;  // registers per 0x10 request
inline constexpr int kMaxPdu = 253;
inline constexpr int kMbapSize = 7;
inline constexpr int kMaxTcpAdu = kMbapSize - 1 + kMaxPdu;  // 260
inline constexpr int kMaxRtuAdu = 1 + kMaxPdu + 2;          // 256

// CRC-16/MODBUS (polynomial 0xA001 reflected, initial 0xFFFF); sent low byte first.
std::uint16_t Crc16(const std::uint8_t* data, std::size_t n);

// The MBAP header (7 bytes, big-endian fields).
struct Mbap {
  std::uint16_t transaction = 0;
  std::uint16_t protocol = 0;  // 0 = Modbus; anything else is not a Modbus frame
  std::uint16_t length = 0;    // bytes that follow: the unit id and the PDU
  std::uint8_t unit = 0;
};
void PutMbap(const Mbap& h, std::uint8_t out[kMbapSize]);
Mbap GetMbap(const std::uint8_t in[kMbapSize]);
// A length field that frames a PDU (1..kMaxPdu bytes after the unit id); anything else
// means the stream is out of step.
inline bool MbapLengthValid(std::uint16_t length) { return length >= 2 && length <= kMaxPdu + 1; }

// Request PDUs; return their length in bytes. regs are register values (host order).
int PutReadRequest(int address, int count, std::uint8_t* pdu);
int PutWriteRequest(int address, const std::uint16_t* regs, int count, std::uint8_t* pdu);

// A reply PDU as the client checks it against its request.
enum class Reply : std::uint8_t {
  kOk = 0,
  kException,  // function | 0x80 with one exception code (*exception)
  kMalformed,  // another function, a wrong byte count, length or echo
};
// 0x03 reply carrying `count` registers: kOk fills regs[0..count).
Reply CheckReadReply(const std::uint8_t* pdu, int len, int count, std::uint16_t* regs,
                     std::uint8_t* exception);
// 0x10 reply: kOk when it echoes address and count.
Reply CheckWriteReply(const std::uint8_t* pdu, int len, int address, int count,
                      std::uint8_t* exception);

// RTU: the length of the frame that starts at adu[0] (address, function, ...), from the
// first `have` bytes: > 0 the frame length, 0 more bytes are needed to tell, -1 the function
// gives no length (a frame the line's silence must end).
int RtuReplyLength(const std::uint8_t* adu, int have);
int RtuRequestLength(const std::uint8_t* adu, int have);
// RTU: true when the frame's last two bytes are the CRC of the rest.
bool RtuCrcValid(const std::uint8_t* adu, int len);
// RTU: appends the CRC to adu[0..len); returns len + 2.
int PutRtuCrc(std::uint8_t* adu, int len);
// Time a frame of `bytes` characters takes on a serial line [ns]: a start bit, data bits,
// a parity bit unless parity is 'N', stop bits, per character.
std::int64_t RtuFrameNs(int bytes, int baud, int data_bits, char parity, int stop_bits);

}  // namespace mrd::protocol::modbus
