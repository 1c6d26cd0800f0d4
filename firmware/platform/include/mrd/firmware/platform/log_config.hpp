#pragma once
// [log] section of the firmware config: the per-period log (period_log.hpp, docs/logging.md).

#include <cstdint>
#include <string>

namespace mrd::firmware::platform {

struct LogConfig {
  bool enabled = true;                    // with a path: log; false: no log even with one
  std::string path;                       // the log file; "" = no log (--log FILE sets it)
  std::uint64_t max_bytes = 64ULL << 20;  // per file [bytes]; then rotate
  std::uint32_t files = 4;                // files kept: PATH (newest), PATH.1, ..., PATH.<files-1>
  std::uint32_t ring_records = 8192;      // ring between loop and writer (rounded up to 2^n)
  std::uint32_t block_records = 256;      // records per block (at most; a flush writes fewer)
  std::int64_t flush_ns = 200'000'000;    // a partial block is written after this long [ns]
  bool sync = false;                      // fdatasync after each block (power-cut safety, SD wear)
};

}  // namespace mrd::firmware::platform
