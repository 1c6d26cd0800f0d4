#pragma once
// Loading a coefficient table image from a file (start-up only).

#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"

namespace mrd::firmware {

// Reads and decodes the table at path. kIo when the file cannot be opened or read, else the
// decoder's errors (kBadSize for a file longer or shorter than kTableSize). No allocation.
Result<CoefficientTable> LoadTableFile(const char* path);

}  // namespace mrd::firmware
