#include "mrd/host/input_error.hpp"

#include <fmt/format.h>

#include "mrd/common/input_file.hpp"

namespace mrd::host {
namespace {

// Reasons echo user input: control and non-ASCII bytes are shown as \xNN and the reason is cut
// at kMaxReason characters, so a binary file or a 10 MB field does not flood the terminal.
constexpr std::size_t kMaxReason = 400;

std::string Printable(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (out.size() >= kMaxReason) {
      out += fmt::format("... ({} more bytes)", text.size() - i);
      break;
    }
    const auto c = static_cast<unsigned char>(text[i]);
    if ((c < 0x20 && c != '\n' && c != '\t') || c >= 0x7f) {
      out += fmt::format("\\x{:02x}", c);
    } else {
      out += static_cast<char>(c);
    }
  }
  return out;
}

std::string Format(const std::string& file_raw, std::size_t line, const std::string& reason_raw) {
  const std::string file = Printable(file_raw);
  const std::string reason = Printable(reason_raw);
  if (file.empty()) return reason;
  if (line == 0) return fmt::format("{}: {}", file, reason);
  return fmt::format("{}:{}: {}", file, line, reason);
}

}  // namespace

InputError::InputError(const std::string& file, std::size_t line, const std::string& reason)
    : std::runtime_error(Format(file, line, reason)), file_(file), line_(line) {}

std::string ReadInputText(const std::string& path, std::uint64_t max_bytes) {
  std::string text, reason;
  if (ReadInputFileOrWhy(path, max_bytes, &text, &reason)) return text;
  throw InputError(path, 0, reason);  // InputError names the file
}

}  // namespace mrd::host
