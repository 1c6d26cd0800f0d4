#include "csv_tokenizer.hpp"

#include <fmt/format.h>

#include "mrd/host/input_error.hpp"

namespace mrd::host::csv {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

std::vector<Line> SplitLines(std::string_view content, const std::string& path) {
  std::vector<Line> lines;
  std::size_t start = 0;
  std::size_t number = 1;
  while (start < content.size()) {
    std::size_t end = content.find('\n', start);
    if (end == std::string_view::npos) end = content.size();
    std::string_view text = content.substr(start, end - start);
    if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
    if (text.find('\r') != std::string_view::npos) {
      throw InputError(path, number,
                       "carriage return inside a line (CR-only line ends?); lines must end in "
                       "LF or CR LF");
    }
    lines.push_back({text, number++});
    start = end + 1;
  }
  return lines;
}

void SplitFields(std::string_view line, char sep, std::vector<std::string_view>* out) {
  out->clear();
  std::size_t start = 0;
  while (true) {
    const std::size_t pos = line.find(sep, start);
    out->push_back(Trim(line.substr(start, pos - start)));
    if (pos == std::string_view::npos) break;
    start = pos + 1;
  }
}

std::string ReadFile(const std::string& path) { return ReadInputText(path, kMaxDataFileBytes); }

}  // namespace mrd::host::csv
