#include "mrd/runlog/runlog.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <span>

#include "mrd/common/crc32.hpp"

namespace mrd::runlog {
namespace {

std::uint32_t Crc(const void* p, std::size_t n, std::uint32_t crc = 0) {
  return Crc32(std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(p), n), crc);
}

void AppendU8(std::string* s, std::uint8_t v) { s->push_back(static_cast<char>(v)); }
void AppendU16(std::string* s, std::uint16_t v) {
  for (int i = 0; i < 2; ++i) s->push_back(static_cast<char>((v >> (8 * i)) & 0xFFU));
}
void AppendU32(std::string* s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s->push_back(static_cast<char>((v >> (8 * i)) & 0xFFU));
}
void AppendU64(std::string* s, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) s->push_back(static_cast<char>((v >> (8 * i)) & 0xFFU));
}
void AppendText(std::string* s, const std::string& t, std::size_t max) {
  const std::size_t n = t.size() < max ? t.size() : max;
  if (max == 255) {
    AppendU8(s, static_cast<std::uint8_t>(n));
  } else {
    AppendU16(s, static_cast<std::uint16_t>(n));
  }
  s->append(t, 0, n);
}

std::uint64_t Get(const std::uint8_t* p, int n) {
  std::uint64_t v = 0;
  for (int i = n - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

// Bounds-checked cursor over the header.
struct Cursor {
  const std::uint8_t* p;
  std::size_t size;
  std::size_t at = 0;
  bool ok = true;
  std::uint64_t Take(int n) {
    if (!ok || size - at < static_cast<std::size_t>(n)) return ok = false, 0;
    const std::uint64_t v = Get(p + at, n);
    at += static_cast<std::size_t>(n);
    return v;
  }
  std::string Text(std::size_t n) {
    if (!ok || size - at < n) return ok = false, std::string();
    std::string t(reinterpret_cast<const char*>(p + at), n);
    at += n;
    return t;
  }
};

}  // namespace

std::size_t TypeSize(Type type) {
  switch (type) {
    case Type::kU8:
      return 1;
    case Type::kU32:
      return 4;
    case Type::kU64:
    case Type::kI64:
    case Type::kF64:
      return 8;
  }
  return 0;
}

const char* TypeName(Type type) {
  switch (type) {
    case Type::kU8:
      return "u8";
    case Type::kU32:
      return "u32";
    case Type::kU64:
      return "u64";
    case Type::kI64:
      return "i64";
    case Type::kF64:
      return "f64";
  }
  return "?";
}

std::uint32_t Header::record_bytes() const {
  std::uint32_t n = 0;
  for (const Field& f : fields) n += static_cast<std::uint32_t>(TypeSize(f.type));
  return n;
}

std::vector<std::uint32_t> Header::Offsets() const {
  std::vector<std::uint32_t> o;
  o.reserve(fields.size());
  std::uint32_t at = 0;
  for (const Field& f : fields) {
    o.push_back(at);
    at += static_cast<std::uint32_t>(TypeSize(f.type));
  }
  return o;
}

std::string EncodeHeader(const Header& h) {
  const std::size_t nf = h.fields.size() < kMaxFields ? h.fields.size() : kMaxFields;
  std::string s(kMagic, sizeof kMagic);
  AppendU16(&s, h.version);
  AppendU16(&s, static_cast<std::uint16_t>(nf));
  const std::size_t size_at = s.size();
  AppendU32(&s, 0);  // header bytes, below
  std::uint32_t record = 0;
  for (std::size_t i = 0; i < nf; ++i)
    record += static_cast<std::uint32_t>(TypeSize(h.fields[i].type));
  AppendU32(&s, record);
  AppendU32(&s, h.file_index);
  AppendU64(&s, static_cast<std::uint64_t>(h.period_ns));
  AppendText(&s, h.source, 65535);
  for (std::size_t i = 0; i < nf; ++i) {
    AppendU8(&s, static_cast<std::uint8_t>(h.fields[i].type));
    AppendText(&s, h.fields[i].name, 255);
    AppendText(&s, h.fields[i].unit, 255);
  }
  const auto total = static_cast<std::uint32_t>(s.size() + 4);
  for (int i = 0; i < 4; ++i) s[size_at + i] = static_cast<char>((total >> (8 * i)) & 0xFFU);
  AppendU32(&s, Crc(s.data(), s.size()));
  return s;
}

void EncodeBlock(std::uint32_t sequence, std::uint64_t dropped, const std::uint8_t* records,
                 std::uint32_t count, std::uint32_t record_bytes, std::string* out) {
  const std::size_t payload = static_cast<std::size_t>(count) * record_bytes;
  std::uint8_t head[kBlockHeaderBytes] = {};  // no allocation: out's capacity may suffice
  PutU32(head, kBlockMagic);
  PutU32(head + 4, sequence);
  PutU32(head + 8, count);
  PutU64(head + 16, dropped);  // CRC (12..15) 0 while computed
  PutU32(head + 12, Crc(records, payload, Crc(head, sizeof head)));
  out->append(reinterpret_cast<const char*>(head), sizeof head);
  out->append(reinterpret_cast<const char*>(records), payload);
}

void PutU8(std::uint8_t* p, std::uint8_t v) { p[0] = v; }
void PutU32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void PutU64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void PutF64(std::uint8_t* p, double v) {
  std::uint64_t u = 0;
  std::memcpy(&u, &v, sizeof u);
  PutU64(p, u);
}

bool DecodeLog(std::string_view bytes, Log* log, std::string* error) {
  *log = Log{};
  log->file_bytes = bytes.size();
  const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data());
  if (bytes.size() < sizeof kMagic || std::memcmp(p, kMagic, sizeof kMagic) != 0) {
    *error = "not an mrd per-period log (no MRDLOG magic at the start)";
    return false;
  }
  Cursor c{p, bytes.size(), sizeof kMagic};
  const auto version = static_cast<std::uint16_t>(c.Take(2));
  if (c.ok && version != kVersion) {
    *error = "log format version " + std::to_string(version) + "; this program reads version " +
             std::to_string(kVersion);
    return false;
  }
  const auto nf = static_cast<std::size_t>(c.Take(2));
  const auto header_bytes = static_cast<std::size_t>(c.Take(4));
  if (!c.ok || header_bytes > bytes.size()) {
    *error = "truncated header (the file has " + std::to_string(bytes.size()) + " bytes" +
             (c.ok ? ", the header " + std::to_string(header_bytes) : std::string()) + ")";
    return false;
  }
  if (header_bytes < c.at + 4 + 4 + 8 + 2 + 4) {
    *error = "corrupt header (length " + std::to_string(header_bytes) + ")";
    return false;
  }
  const std::uint32_t stored = static_cast<std::uint32_t>(Get(p + header_bytes - 4, 4));
  if (Crc(p, header_bytes - 4) != stored) {
    *error = "corrupt header (CRC mismatch)";
    return false;
  }
  Header& h = log->header;
  h.version = version;
  c.size = header_bytes - 4;  // fields end before the CRC
  const auto record_bytes = static_cast<std::uint32_t>(c.Take(4));
  h.file_index = static_cast<std::uint32_t>(c.Take(4));
  h.period_ns = static_cast<std::int64_t>(c.Take(8));
  h.source = c.Text(static_cast<std::size_t>(c.Take(2)));
  for (std::size_t i = 0; i < nf && c.ok; ++i) {
    Field f;
    f.type = static_cast<Type>(c.Take(1));
    f.name = c.Text(static_cast<std::size_t>(c.Take(1)));
    f.unit = c.Text(static_cast<std::size_t>(c.Take(1)));
    if (!c.ok) break;
    if (TypeSize(f.type) == 0) {
      *error = "corrupt header (field " + std::to_string(i) + " has unknown type code " +
               std::to_string(static_cast<unsigned>(f.type)) + ")";
      return false;
    }
    if (f.name.empty() || FieldIndex(h, f.name) >= 0) {
      *error = "corrupt header (field " + std::to_string(i) + " has an empty or repeated name)";
      return false;
    }
    h.fields.push_back(std::move(f));
  }
  if (!c.ok || c.at != c.size) {
    *error = "corrupt header (field table does not fill the header)";
    return false;
  }
  if (h.fields.empty() || h.record_bytes() != record_bytes) {
    *error = "corrupt header (record size " + std::to_string(record_bytes) +
             " does not match the fields)";
    return false;
  }

  // Blocks.
  std::size_t at = header_bytes;
  log->valid_bytes = at;
  std::uint64_t index = 0;
  while (at < bytes.size()) {
    const std::size_t left = bytes.size() - at;
    const auto damaged = [&](Damage d, std::string why) {
      log->damage = d;
      log->damage_block = index;
      log->damage_offset = at;
      log->damage_reason = std::move(why);
    };
    if (left < kBlockHeaderBytes) {
      damaged(Damage::kTruncated,
              "the file ends " + std::to_string(left) + " bytes into a block header");
      break;
    }
    const std::uint8_t* b = p + at;
    if (Get(b, 4) != kBlockMagic) {
      damaged(Damage::kCorrupt, "no block magic");
      break;
    }
    const auto seq = Get(b + 4, 4);
    const auto count = Get(b + 8, 4);
    const auto crc = static_cast<std::uint32_t>(Get(b + 12, 4));
    const std::uint64_t dropped = Get(b + 16, 8);
    if (count == 0 || count > (std::uint64_t{1} << 24)) {
      damaged(Damage::kCorrupt, "implausible record count " + std::to_string(count));
      break;
    }
    const std::uint64_t payload = count * record_bytes;
    if (left - kBlockHeaderBytes < payload) {
      damaged(Damage::kTruncated, "the file ends " + std::to_string(left) +
                                      " bytes into a block of " +
                                      std::to_string(kBlockHeaderBytes + payload) + " bytes");
      break;
    }
    std::uint8_t head[kBlockHeaderBytes];
    std::memcpy(head, b, sizeof head);
    std::memset(head + 12, 0, 4);
    const std::uint32_t want =
        Crc(b + kBlockHeaderBytes, static_cast<std::size_t>(payload), Crc(head, sizeof head));
    if (want != crc) {
      damaged(Damage::kCorrupt, "CRC mismatch");
      break;
    }
    if (log->blocks == 0) {
      log->first_sequence = seq;
    } else if (seq > log->last_sequence + 1) {
      log->sequence_gaps += seq - log->last_sequence - 1;
    }
    log->last_sequence = seq;
    log->dropped = dropped;
    const auto n = static_cast<std::size_t>(payload);  // fits: within the file's bytes
    log->records.insert(log->records.end(), b + kBlockHeaderBytes, b + kBlockHeaderBytes + n);
    log->num_records += count;
    ++log->blocks;
    ++index;
    at += kBlockHeaderBytes + n;
    log->valid_bytes = at;
  }
  return true;
}

bool ReadLog(const std::string& path, Log* log, std::string* error, std::uint64_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    *error = path + ": cannot open (" + std::strerror(errno) + ")";
    return false;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    *error = path + ": not a regular file";
    return false;
  }
  if (static_cast<std::uint64_t>(st.st_size) > max_bytes) {
    ::close(fd);
    *error = path + ": " + std::to_string(st.st_size) + " bytes, more than the " +
             std::to_string(max_bytes) + " this reader takes";
    return false;
  }
  std::string bytes;
  bytes.resize(static_cast<std::size_t>(st.st_size));
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = ::read(fd, bytes.data() + got, bytes.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      *error = path + ": read error (" + std::strerror(errno) + ")";
      ::close(fd);
      return false;
    }
    if (n == 0) break;  // shrank meanwhile
    got += static_cast<std::size_t>(n);
  }
  ::close(fd);
  bytes.resize(got);
  if (!DecodeLog(bytes, log, error)) {
    *error = path + ": " + *error;
    return false;
  }
  return true;
}

double Value(const Log& log, const std::vector<std::uint32_t>& offsets, std::uint64_t r,
             std::size_t i) {
  const std::uint8_t* p =
      log.records.data() + static_cast<std::size_t>(r * log.header.record_bytes() + offsets[i]);
  switch (log.header.fields[i].type) {
    case Type::kU8:
      return p[0];
    case Type::kU32:
      return static_cast<double>(Get(p, 4));
    case Type::kU64:
      return static_cast<double>(Get(p, 8));
    case Type::kI64:
      return static_cast<double>(static_cast<std::int64_t>(Get(p, 8)));
    case Type::kF64: {
      const std::uint64_t u = Get(p, 8);
      double d = 0.0;
      std::memcpy(&d, &u, sizeof d);
      return d;
    }
  }
  return 0.0;
}

std::uint64_t Bits(const Log& log, const std::vector<std::uint32_t>& offsets, std::uint64_t r,
                   std::size_t i) {
  const std::uint8_t* p =
      log.records.data() + static_cast<std::size_t>(r * log.header.record_bytes() + offsets[i]);
  return Get(p, static_cast<int>(TypeSize(log.header.fields[i].type)));
}

int FieldIndex(const Header& header, std::string_view name) {
  for (std::size_t i = 0; i < header.fields.size(); ++i) {
    if (header.fields[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace mrd::runlog
