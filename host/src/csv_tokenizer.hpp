#pragma once
// The one CSV tokenizer of the host (csv.cpp reads toolkit files, import.cpp foreign ones):
// lines ending in "\n" or "\r\n", fields split at a one-character separator and trimmed of
// blanks. A carriage return inside a line (CR-only line ends) is an error, never data.

#include <string>
#include <string_view>
#include <vector>

namespace mrd::host::csv {

struct Line {
  std::string_view text;  // without the line end ("\n" or "\r\n")
  std::size_t number;     // 1-based file line
};

// Strips blanks (space, tab) at both ends and a trailing carriage return.
std::string_view Trim(std::string_view s);

// Lines of content; the empty string after a final line end is not a line. Throws InputError
// (path, line) on a carriage return inside a line.
std::vector<Line> SplitLines(std::string_view content, const std::string& path);

// Fields of a line, trimmed. Separators inside quotes are not supported.
void SplitFields(std::string_view line, char sep, std::vector<std::string_view>* out);

// Reads a whole regular file of at most kMaxDataFileBytes; throws InputError(path, 0, reason)
// when it cannot (a directory, a FIFO, too large, a system error).
std::string ReadFile(const std::string& path);

}  // namespace mrd::host::csv
