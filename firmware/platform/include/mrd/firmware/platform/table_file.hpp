#pragma once
// Loading a coefficient table image from a file (start-up only).

#include <string>

#include "mrd/common/model_check.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"

namespace mrd::firmware::platform {

// Reads and decodes the table at path. kIo when the path cannot be opened or read or is not a
// regular file (a directory, FIFO or device is refused without blocking), kBadSize for a file
// longer or shorter than a table image, else the decoder's errors. No allocation.
Result<CoefficientTable> LoadTableFile(const char* path);
// The same; on failure *reason says why in words ("is a FIFO, not a regular file", "CRC
// mismatch", "value out of range: byte 17 (header, reserved) is 0x01, must be 0", ...).
Result<CoefficientTable> LoadTableFile(const char* path, std::string* reason);

// Words for a decoder refusal (DecodeTable with a TableDiagnosis): the error's name and what
// is wrong where, with the offending values.
std::string DescribeTableRefusal(const TableDiagnosis& why);

}  // namespace mrd::firmware::platform
