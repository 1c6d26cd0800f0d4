#pragma once
// Reading a user's input file (config, scenario, table, excitation trace) without the ways it
// can hang or exhaust the process, and echoing user input in messages. Start-up only.
//
// A FIFO, a terminal or a device never blocks the open (O_NONBLOCK), and only a regular file
// is read: a directory, FIFO, socket or device (/dev/zero) is refused, and so is a file
// larger than the caller's limit (said in the reason).

#include <cstdint>
#include <string>
#include <string_view>

namespace mrd {

// Result of OpenInputFile. fd >= 0: an open, read-only, close-on-exec descriptor of a regular
// file of `size` bytes (the caller closes it). fd < 0: refused, for the reason below.
struct InputFile {
  int fd = -1;
  std::uint64_t size = 0;  // [bytes]
  int error = 0;           // errno of a failed open or fstat (0 otherwise)
  const char* kind = "";   // what the path is when it is not a regular file ("a directory")
  bool too_large = false;  // a regular file over the limit
};

// Opens path for reading if it is a regular file of at most max_bytes. No allocation.
InputFile OpenInputFile(const char* path, std::uint64_t max_bytes);

// The reason OpenInputFile refused (e.g. "is a FIFO, not a regular file", "is 5 000 000 bytes,
// larger than the limit of 1048576 bytes", "No such file or directory").
std::string InputFileRefusal(const InputFile& f, std::uint64_t max_bytes);

// Reads the whole regular file (OpenInputFile) into *text. false with *error =
// "PATH: reason" (PATH as Printable) when refused or unreadable (a file that grew past the
// limit while being read is refused too).
bool ReadInputFile(const std::string& path, std::uint64_t max_bytes, std::string* text,
                   std::string* error);

// The same with the reason alone in *reason (no path), for callers that name the file in
// their own error format.
bool ReadInputFileOrWhy(const std::string& path, std::uint64_t max_bytes, std::string* text,
                        std::string* reason);

// User input made safe to echo in one message line: control and non-ASCII bytes as \xNN,
// cut after max_chars characters with "... (N more bytes)".
inline constexpr std::size_t kMaxEchoChars = 400;
std::string Printable(std::string_view text, std::size_t max_chars = kMaxEchoChars);

}  // namespace mrd
