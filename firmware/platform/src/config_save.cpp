// Compiled with exceptions (toml++ for the source positions); every exception is caught here.
#include "mrd/firmware/platform/config_save.hpp"

#include <sys/stat.h>
#include <toml++/toml.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <sstream>
#include <vector>

#include "mrd/common/input_file.hpp"
#include "mrd/common/write_atomically.hpp"

namespace mrd::firmware::platform {
namespace {

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// Writes text over path (which must exist) keeping its permission bits. "" or the reason.
std::string Save(const std::string& path, const std::string& text) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return Errno("cannot stat " + path);
  AtomicWriter file;
  if (file.Open(path, {.keep_mode = true}) && file.Write(text) && file.Commit()) return "";
  return file.Error("saved");
}

}  // namespace

std::string SaveConfigFile(const std::string& path, const FirmwareConfig& running) {
  try {
    std::string text, error;
    if (!ReadInputFile(path, kMaxConfigBytes, &text, &error)) return error;
    FirmwareConfig on_file;
    if (!ParseConfig(text, path, &on_file, &error)) {
      return "the file no longer parses, nothing saved: " + error;
    }
    const toml::table root = toml::parse(text, path);
    const std::vector<ParamInfo> now = ListParams(running);
    const std::vector<ParamInfo> before = ListParams(on_file);
    if (now.size() != before.size()) return "internal error: parameter tables differ";

    std::vector<std::string> lines = Lines(text);
    std::map<std::size_t, std::vector<std::string>> insert_after;  // line index -> new lines
    std::map<std::string, std::vector<std::string>> new_sections;  // section -> new lines
    std::vector<std::string> order;                                // of new sections
    for (std::size_t i = 0; i < now.size(); ++i) {
      const ParamInfo& p = now[i];
      if (p.tunable != Tunable::kRuntime) continue;
      // e_max on file is the table's unless given: written only when set while running.
      const bool changed = p.name == "control.e_max"
                               ? running.e_max.has_value() && running.e_max != on_file.e_max
                               : p.value != before[i].value;
      if (!changed) continue;
      const std::string section = p.name.substr(0, p.name.find('.'));
      const std::string key = p.name.substr(p.name.find('.') + 1);
      const toml::node* sec = root.get(section);
      const toml::node* node =
          sec != nullptr && sec->is_table() ? sec->as_table()->get(key) : nullptr;
      if (node != nullptr) {
        const toml::source_region& r = node->source();
        if (r.begin.line != r.end.line || r.begin.line == 0 || r.begin.line > lines.size()) {
          return "cannot rewrite " + p.name + " in place (a value over several lines)";
        }
        std::string& line = lines[r.begin.line - 1];
        const std::size_t from = r.begin.column - 1, to = r.end.column - 1;
        if (to > line.size() || from > to) return "cannot rewrite " + p.name + " in place";
        line.replace(from, to - from, p.value);
      } else if (sec != nullptr) {
        const toml::table* t = sec->as_table();
        const std::size_t at = t != nullptr ? sec->source().begin.line : 0;
        if (t == nullptr || t->is_inline() || at == 0 || at > lines.size() ||
            lines[at - 1].find('[') == std::string::npos) {
          return "cannot add " + p.name + ": [" + section + "] is not a plain table header";
        }
        insert_after[at - 1].push_back(key + " = " + p.value);
      } else {
        if (new_sections.find(section) == new_sections.end()) order.push_back(section);
        new_sections[section].push_back(key + " = " + p.value);
      }
    }
    std::string out;
    for (std::size_t i = 0; i < lines.size(); ++i) {
      out += lines[i] + "\n";
      if (const auto it = insert_after.find(i); it != insert_after.end()) {
        for (const std::string& l : it->second) out += l + "\n";
      }
    }
    for (const std::string& section : order) {
      out += "\n[" + section + "]\n";
      for (const std::string& l : new_sections[section]) out += l + "\n";
    }
    // The file must give back the running values before it replaces the old one.
    FirmwareConfig check;
    if (!ParseConfig(out, path, &check, &error)) {
      return "internal error: the saved text would not parse (" + error + "); nothing saved";
    }
    const std::vector<ParamInfo> after = ListParams(check);
    for (std::size_t i = 0; i < now.size() && i < after.size(); ++i) {
      if (now[i].tunable != Tunable::kRuntime || now[i].name == "control.e_max") continue;
      if (now[i].value != after[i].value) {
        return "internal error: the saved file would give " + now[i].name + " = " + after[i].value +
               ", not " + now[i].value + "; nothing saved";
      }
    }
    if (running.e_max.has_value() && check.e_max != running.e_max) {
      return "internal error: the saved file would not keep control.e_max; nothing saved";
    }
    return Save(path, out);
  } catch (const toml::parse_error& e) {
    return path + ": " + std::string(e.description());
  } catch (const std::exception& e) {
    return path + ": " + e.what();
  }
}

}  // namespace mrd::firmware::platform
