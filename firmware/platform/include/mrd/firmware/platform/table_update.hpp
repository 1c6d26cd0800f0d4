#pragma once
// Installing a coefficient table on a board: atomic replace with the previous table kept, and
// rollback. Start-up / maintenance only (not the real-time path). Files beside DEST:
//   DEST.tmp-XXXXXX       staging copies (unique names, created with O_EXCL: a symlink or file
//                         planted at any name is never written through); removed on failure,
//                         and by the next install when a killed one left them
//   DEST.prev.tmp-XXXXXX  the previous table's hard link on its way to DEST.prev
//   DEST.prev             the table DEST held before the last install
//   DEST.refused          the table a rollback removed from DEST
//   DEST.lock             flock'ed by each install and rollback: one at a time per DEST

#include <string>

#include "mrd/common/table.hpp"
#include "mrd/firmware/platform/config.hpp"

namespace mrd::firmware::platform {

// Decodes the table at path (regular file, size, CRC, format and content rules) and
// configures a controller with it and config (compatibility with this firmware: channels,
// invertibility, E_max and safe voltage within the table's range). Returns "" when accepted,
// else the reason.
std::string CheckTable(const char* path, const FirmwareConfig& config);

// Writes the table's image to path: a new temporary beside it (every write, fsync and close
// checked), renamed onto path, folder fsynced. A path that exists and is not a regular file
// (symlink, device such as /dev/full, FIFO, folder) is refused. "" on success, else the
// reason (path unchanged, no temporary left).
std::string WriteTableFile(const char* path, const CoefficientTable& table);

// Checks source (CheckTable), takes DEST.lock, writes a staging copy, fsyncs it, re-reads and
// checks it, hard-links the current DEST (if any) to DEST.prev, renames the copy onto DEST
// and fsyncs the folder. DEST exists throughout; a DEST that is not a regular file is refused.
// Returns "" on success, else the reason (DEST unchanged).
std::string InstallTable(const char* source, const char* dest, const FirmwareConfig& config);

// When DEST is refused (CheckTable) and DEST.prev is accepted: DEST -> DEST.refused,
// DEST.prev -> DEST (atomic rename), under DEST.lock. Returns "" when DEST is accepted
// (nothing done, no lock taken) or was rolled back (*rolled_back set), else the reason why
// neither table can be used.
std::string CheckTableOrRollBack(const char* dest, const FirmwareConfig& config, bool* rolled_back);

}  // namespace mrd::firmware::platform
