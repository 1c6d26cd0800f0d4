#include "profile_context.hpp"

namespace mrd::profile {

bool ProfileContext::Fail(const toml::node* at, const std::string& why) const {
  const auto line = at != nullptr ? at->source().begin.line : 1u;
  *error = path + ":" + std::to_string(line) + ": " + why;
  return false;
}

std::string ProfileDirectory(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

bool ParseProfileToml(const std::string& text, const std::string& path, toml::table* root,
                      std::string* error) {
  try {
    *root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    *error =
        path + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description());
    return false;
  }
  return true;
}

}  // namespace mrd::profile
