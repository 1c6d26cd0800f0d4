#pragma once
// CANopen (CiA 301) frames the firmware and the harness exchange with a drive, as pure
// functions on 8-byte payloads (no allocation, no exceptions, no I/O):
//   NMT      COB-ID 0x000, 2 bytes [command, node id]   (0x01 start remote node, ...)
//   SYNC     COB-ID 0x080, no data
//   EMCY     COB-ID 0x080 + node (the drive's; only reserved here)
//   SDO      request 0x600 + node (client -> server), response 0x580 + node (server -> client)
//   heartbeat 0x700 + node, 1 byte: the producer's NMT state (0x00 boot-up, 0x04 stopped,
//            0x05 operational, 0x7F pre-operational)
// Expedited SDO download (the only SDO transfer used): request byte 0 = 0x23 / 0x27 / 0x2B /
// 0x2F for 4 / 3 / 2 / 1 data bytes, bytes 1-2 the index (little-endian), byte 3 the
// subindex, bytes 4-7 the value (little-endian, unused bytes 0). Response byte 0 = 0x60 with
// the same index and subindex. Abort: byte 0 = 0x80, index, subindex, bytes 4-7 the abort code
// (little-endian).

#include <cstdint>

namespace mrd::profile::canopen {

inline constexpr std::uint32_t kNmtId = 0x000;
inline constexpr std::uint32_t kSyncId = 0x080;
constexpr std::uint32_t EmcyId(int node) { return 0x080U + static_cast<std::uint32_t>(node); }
constexpr std::uint32_t SdoRequestId(int node) { return 0x600U + static_cast<std::uint32_t>(node); }
constexpr std::uint32_t SdoResponseId(int node) {
  return 0x580U + static_cast<std::uint32_t>(node);
}
constexpr std::uint32_t HeartbeatId(int node) { return 0x700U + static_cast<std::uint32_t>(node); }

// NMT commands (byte 0 of an NMT frame).
inline constexpr std::uint8_t kNmtStart = 0x01;  // start remote node -> operational
inline constexpr std::uint8_t kNmtStop = 0x02;   // -> stopped
inline constexpr std::uint8_t kNmtPreOperational = 0x80;
inline constexpr std::uint8_t kNmtResetNode = 0x81;
inline constexpr std::uint8_t kNmtResetCommunication = 0x82;

// NMT states (the heartbeat's byte; bit 7 is the legacy node-guarding toggle and is masked).
inline constexpr std::uint8_t kStateBootUp = 0x00;
inline constexpr std::uint8_t kStateStopped = 0x04;
inline constexpr std::uint8_t kStateOperational = 0x05;
inline constexpr std::uint8_t kStatePreOperational = 0x7F;
// "boot-up", "stopped", "operational", "pre-operational" or "unknown".
const char* NmtStateName(std::uint8_t state);

// The expedited download request of `size` (1, 2 or 4) bytes of `value` (its low bytes, two's
// complement for a negative one) to index:subindex. false (out untouched) for another size.
bool EncodeSdoDownload(std::uint16_t index, std::uint8_t subindex, int size, std::int64_t value,
                       std::uint8_t out[8]);

// A download request as a server reads it. Expedited with the size indicated: *size 1..4;
// expedited without it: *size 4. false for anything else (a segmented or upload request).
bool DecodeSdoDownloadRequest(const std::uint8_t* data, int len, std::uint16_t* index,
                              std::uint8_t* subindex, int* size, std::uint32_t* raw);
void EncodeSdoDownloadAck(std::uint16_t index, std::uint8_t subindex, std::uint8_t out[8]);
void EncodeSdoAbort(std::uint16_t index, std::uint8_t subindex, std::uint32_t code,
                    std::uint8_t out[8]);

enum class SdoReply : std::uint8_t {
  kAck = 0,  // download confirmed (0x60, same index and subindex)
  kAbort,    // refused: *abort_code says why
  kOther,    // not an answer to this request (another object, a short frame, upload data)
};
// A server's answer to the download of index:subindex.
SdoReply DecodeSdoReply(const std::uint8_t* data, int len, std::uint16_t index,
                        std::uint8_t subindex, std::uint32_t* abort_code);

// The CiA 301 meaning of an SDO abort code ("value range of parameter exceeded"), or
// "unknown abort code" for one the standard does not list.
const char* SdoAbortText(std::uint32_t code);

}  // namespace mrd::profile::canopen
