#pragma once
// A user's input file read line by line (input_file.hpp's limits and refusals), for loaders
// whose errors name the line. Start-up only.
#include <cstddef>
#include <cstdint>
#include <string>

namespace mrd {

// A user's text file line by line (as std::getline splits it), for a loader whose errors
// name the line: "FILE:LINE: reason", FILE as Printable.
class InputLines {
 public:
  // Reads the whole file (ReadInputFile). false: *error says why.
  bool Read(const std::string& path, std::uint64_t max_bytes, std::string* error);
  // The next line into *line, without its '\n'; number() counts from 1. false at the end.
  bool Next(std::string* line);
  // *error = "FILE:LINE: why" (LINE: the latest line read); returns false.
  bool Fail(const std::string& why, std::string* error) const;
  const std::string& where() const { return where_; }  // the path as Printable
  int number() const { return number_; }

 private:
  std::string text_;
  std::size_t at_ = 0;  // the next line's first byte in text_
  std::string where_;
  int number_ = 0;
};

}  // namespace mrd
