#pragma once
// Installing a coefficient table on a board: atomic replace with the previous table kept, and
// rollback. Start-up / maintenance only (not the real-time path). Files beside DEST:
//   DEST.new      staging copy (written, fsynced, verified, then renamed onto DEST)
//   DEST.prev     the table DEST held before the last install
//   DEST.refused  the table a rollback removed from DEST

#include <string>

#include "mrd/firmware/config.hpp"

namespace mrd::firmware {

// Decodes the table at path (size, CRC, format) and configures a controller with it and
// config (compatibility with this firmware: channels, invertibility, E_max and safe voltage
// within the table's range). Returns "" when accepted, else the reason.
std::string CheckTable(const char* path, const FirmwareConfig& config);

// Checks source (CheckTable), writes DEST.new, fsyncs it, re-reads and checks it, hard-links
// the current DEST (if any) to DEST.prev, renames DEST.new onto DEST and fsyncs the folder.
// DEST exists throughout. Returns "" on success, else the reason (DEST unchanged).
std::string InstallTable(const char* source, const char* dest, const FirmwareConfig& config);

// When DEST is refused (CheckTable) and DEST.prev is accepted: DEST -> DEST.refused,
// DEST.prev -> DEST (atomic rename). Returns "" when DEST is accepted (nothing done) or was
// rolled back (*rolled_back set), else the reason why neither table can be used.
std::string CheckTableOrRollBack(const char* dest, const FirmwareConfig& config, bool* rolled_back);

}  // namespace mrd::firmware
