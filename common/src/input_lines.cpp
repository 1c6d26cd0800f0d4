#include "mrd/common/input_lines.hpp"

#include "mrd/common/input_file.hpp"

namespace mrd {

bool InputLines::Read(const std::string& path, std::uint64_t max_bytes, std::string* error) {
  if (!ReadInputFile(path, max_bytes, &text_, error)) return false;
  at_ = 0;
  where_ = Printable(path);
  number_ = 0;
  return true;
}

bool InputLines::Next(std::string* line) {
  if (at_ >= text_.size()) return false;
  const std::size_t nl = text_.find('\n', at_);
  const std::size_t end = nl == std::string::npos ? text_.size() : nl;
  line->assign(text_, at_, end - at_);
  at_ = nl == std::string::npos ? text_.size() : nl + 1;
  ++number_;
  return true;
}

bool InputLines::Fail(const std::string& why, std::string* error) const {
  *error = where_ + ":" + std::to_string(number_) + ": " + why;
  return false;
}

}  // namespace mrd
