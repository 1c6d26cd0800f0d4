#pragma once
// The per-period log's file format, version 1 (docs/logging.md). All integers little-endian.
//
//   file   = header, block*
//   header = magic "MRDLOG\r\n" (8), u16 version, u16 field count, u32 header bytes (all of
//            it, CRC included), u32 record bytes, u32 file index (0, 1, ... per rotation),
//            i64 period [ns], u16 source length, source (text),
//            per field: u8 type, u8 name length, name, u8 unit length, unit;
//            u32 CRC-32 of everything before it
//   block  = u32 magic "MRDB", u32 sequence (from 0, continued across rotated files),
//            u32 record count (>= 1), u32 CRC-32 (of the block header with this field 0,
//            then the records), u64 records dropped so far (the writer's ring was full),
//            count * record bytes (fields packed in header order, no padding)
//
// Reading: a file that ends inside a block (power cut, kill -9) is read up to its last whole
// block and flagged truncated; a block whose magic, count or CRC is wrong stops the reading
// there (flagged corrupt, with its index and offset). The header must be whole and valid.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace mrd::runlog {

inline constexpr char kMagic[8] = {'M', 'R', 'D', 'L', 'O', 'G', '\r', '\n'};
inline constexpr std::uint16_t kVersion = 1;
inline constexpr std::uint32_t kBlockMagic = 0x4244524DU;  // "MRDB" in file order
inline constexpr std::size_t kBlockHeaderBytes = 24;
inline constexpr std::size_t kMaxFields = 255;

enum class Type : std::uint8_t { kU8 = 1, kU32 = 2, kU64 = 3, kI64 = 4, kF64 = 5 };

// Bytes of one value; 0 for an unknown type code.
std::size_t TypeSize(Type type);
// "u8", "u32", "u64", "i64", "f64"; "?" for an unknown code.
const char* TypeName(Type type);

struct Field {
  std::string name;  // 1 ... 255 bytes, unique
  Type type = Type::kF64;
  std::string unit;  // "" when none
};

struct Header {
  std::uint16_t version = kVersion;
  std::uint32_t file_index = 0;
  std::int64_t period_ns = 0;
  std::string source;  // who wrote it (e.g. "mrd-firmware dry run, table compiled-in")
  std::vector<Field> fields;
  std::uint32_t record_bytes() const;  // sum of the fields' sizes
  // Byte offset of each field inside a record.
  std::vector<std::uint32_t> Offsets() const;
};

// The header's bytes (CRC included). Names or units longer than 255 bytes, more than
// kMaxFields fields or a source beyond 65535 bytes are cut (the writer's table has none).
std::string EncodeHeader(const Header& header);
// Appends one block of count records (record_bytes each, packed) with its header to *out;
// allocates nothing when out's capacity holds it.
void EncodeBlock(std::uint32_t sequence, std::uint64_t dropped, const std::uint8_t* records,
                 std::uint32_t count, std::uint32_t record_bytes, std::string* out);

// Little-endian stores into a record buffer (the writer's encoder).
void PutU8(std::uint8_t* p, std::uint8_t v);
void PutU32(std::uint8_t* p, std::uint32_t v);
void PutU64(std::uint8_t* p, std::uint64_t v);
void PutF64(std::uint8_t* p, double v);

enum class Damage : std::uint8_t {
  kNone = 0,
  kTruncated,  // the file ends inside a block: read up to the last whole block
  kCorrupt,    // a block's magic, count or CRC is wrong: read up to the block before it
};

struct Log {
  Header header;
  std::vector<std::uint8_t> records;  // num_records * record_bytes
  std::uint64_t num_records = 0;
  std::uint64_t blocks = 0;          // whole, valid blocks read
  std::uint64_t first_sequence = 0;  // of the first block (0 without blocks)
  std::uint64_t last_sequence = 0;
  std::uint64_t sequence_gaps = 0;  // blocks missing between sequences
  std::uint64_t dropped = 0;        // from the last valid block
  std::uint64_t file_bytes = 0;
  std::uint64_t valid_bytes = 0;  // header and whole valid blocks
  Damage damage = Damage::kNone;
  std::uint64_t damage_block = 0;   // index (from 0, in this file) of the damaged block
  std::uint64_t damage_offset = 0;  // its byte offset
  std::string damage_reason;        // e.g. "CRC mismatch", "ends after 12 of 6168 bytes"
};

// Decodes a whole file's bytes. false with *error for what is not a readable log: not a log
// (bad magic), another version, a truncated or corrupt header, an invalid field table.
// Damaged blocks are not an error: see Log::damage.
bool DecodeLog(std::string_view bytes, Log* log, std::string* error);
// Reads path (at most max_bytes) then DecodeLog; *error starts "PATH: ".
bool ReadLog(const std::string& path, Log* log, std::string* error,
             std::uint64_t max_bytes = std::uint64_t{1} << 32);

// Field i of record r as a double (u64 beyond 2^53 rounds). Index of a field by name, -1.
double Value(const Log& log, const std::vector<std::uint32_t>& offsets, std::uint64_t r,
             std::size_t i);
// Field i of record r as stored: the integer zero-extended to 64 bits (an i64 as its two's
// complement), the IEEE 754 bits of an f64.
std::uint64_t Bits(const Log& log, const std::vector<std::uint32_t>& offsets, std::uint64_t r,
                   std::size_t i);
int FieldIndex(const Header& header, std::string_view name);

}  // namespace mrd::runlog
