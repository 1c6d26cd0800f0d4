#include "mrd/host/input_error.hpp"

#include <fmt/format.h>

namespace mrd::host {
namespace {

std::string Format(const std::string& file, std::size_t line, const std::string& reason) {
  if (file.empty()) return reason;
  if (line == 0) return fmt::format("{}: {}", file, reason);
  return fmt::format("{}:{}: {}", file, line, reason);
}

}  // namespace

InputError::InputError(const std::string& file, std::size_t line, const std::string& reason)
    : std::runtime_error(Format(file, line, reason)), file_(file), line_(line) {}

}  // namespace mrd::host
