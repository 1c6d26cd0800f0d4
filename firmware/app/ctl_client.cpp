// mrd-firmware ctl [--socket PATH] list | get NAME | set NAME VALUE | save
#include "ctl_client.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <string>
#include <vector>

#include "mrd/firmware/platform/config.hpp"
#include "mrd/firmware/platform/params_server.hpp"

namespace mrd::firmware {
namespace {

constexpr const char* kCtlHelp =
    "mrd-firmware ctl: list, read and change the parameters of a running mrd-firmware.\n"
    "\n"
    "Usage:\n"
    "  mrd-firmware ctl [--socket PATH] list\n"
    "  mrd-firmware ctl [--socket PATH] get NAME\n"
    "  mrd-firmware ctl [--socket PATH] set NAME VALUE\n"
    "  mrd-firmware ctl [--socket PATH] save\n"
    "\n"
    "  list   every parameter: name, value, unit, type, when a change takes effect\n"
    "         (runtime: ctl set; reload: SIGHUP; restart), accepted values\n"
    "  get    one parameter, e.g. control.skyhook_gain\n"
    "  set    change a runtime parameter: checked against the same ranges as the config,\n"
    "         applied at a period boundary; prints the period it was applied at. Strings may\n"
    "         be given bare (set control.law skyhook). A refused value changes nothing.\n"
    "  save   write the running parameters into the firmware's config file (atomically;\n"
    "         the other keys and comments stay as they are)\n"
    "\n"
    "  --socket PATH  the firmware's control socket ([ctl] socket, --ctl-socket); default\n"
    "                 $XDG_RUNTIME_DIR/mrd-firmware.sock, else /run/mrd-firmware/ctl.sock\n"
    "\n"
    "Names and ranges: docs/tuning.md, docs/firmware_config.md.\n"
    "Exit status: 0 ok, 1 no firmware at the socket (or it failed), 2 refused or bad input.\n";

std::vector<std::string> Split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  for (const char c : s) {
    if (c == sep) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

// list / get: the reply's tab-separated lines (name, value, type, unit, accepts, set) as a
// table (list) or one line each (get).
void PrintParams(const std::string& cmd, const std::vector<std::string>& lines) {
  std::vector<std::array<std::string, 6>> rows;
  for (const std::string& l : lines) {
    const std::vector<std::string> f = Split(l, '\t');
    if (f.size() == 6) rows.push_back({f[0], f[1], f[3], f[2], f[5], f[4]});
  }
  if (cmd == "get") {
    for (const auto& r : rows) {
      std::printf("%s = %s%s%s (%s, %s; %s)\n", r[0].c_str(), r[1].c_str(), r[2].empty() ? "" : " ",
                  r[2].c_str(), r[3].c_str(), r[5].c_str(), r[4].c_str());
    }
  } else {
    std::array<std::size_t, 6> w{4, 5, 4, 4, 3, 7};
    for (const auto& r : rows) {
      for (std::size_t i = 0; i < 5; ++i) w[i] = std::max(w[i], r[i].size());
    }
    std::printf("%-*s  %-*s  %-*s  %-*s  %-*s  %s\n", static_cast<int>(w[0]), "NAME",
                static_cast<int>(w[1]), "VALUE", static_cast<int>(w[2]), "UNIT",
                static_cast<int>(w[3]), "TYPE", static_cast<int>(w[4]), "SET", "ACCEPTS");
    for (const auto& r : rows) {
      std::printf("%-*s  %-*s  %-*s  %-*s  %-*s  %s\n", static_cast<int>(w[0]), r[0].c_str(),
                  static_cast<int>(w[1]), r[1].c_str(), static_cast<int>(w[2]), r[2].c_str(),
                  static_cast<int>(w[3]), r[3].c_str(), static_cast<int>(w[4]), r[4].c_str(),
                  r[5].c_str());
    }
  }
}

// set: the reply "ok period N version V value VALUE" in words (as it came when shorter).
void PrintSetReply(const std::string& name, const std::string& last) {
  const std::vector<std::string> f = Split(last, ' ');
  if (f.size() >= 7) {
    std::string value = f[6];
    for (std::size_t i = 7; i < f.size(); ++i) value += " " + f[i];
    std::printf("%s = %s: applied at period %s (parameter version %s)\n", name.c_str(),
                value.c_str(), f[2].c_str(), f[4].c_str());
  } else {
    std::printf("%s\n", last.c_str());
  }
}

}  // namespace

int RunCtl(int argc, char** argv) {
  std::string socket = platform::DefaultCtlSocket();
  std::vector<std::string> words;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kCtlHelp, stdout);
      return 0;
    }
    if (a == "--socket" && words.empty()) {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "error: --socket needs a path\n");
        return 2;
      }
      socket = argv[++i];
    } else {
      words.push_back(a);
    }
  }
  const std::string cmd = words.empty() ? "" : words[0];
  const bool ok_args = (cmd == "list" && words.size() == 1) ||
                       (cmd == "get" && words.size() == 2) || (cmd == "set" && words.size() == 3) ||
                       (cmd == "save" && words.size() == 1);
  if (!ok_args) {
    std::fprintf(stderr,
                 "error: usage: mrd-firmware ctl [--socket PATH] list | get NAME | set "
                 "NAME VALUE | save (see mrd-firmware ctl --help)\n");
    return 2;
  }
  for (const std::string& w : words) {
    if (w.find('\n') != std::string::npos || w.find('\r') != std::string::npos) {
      std::fprintf(stderr, "error: arguments must not contain line breaks\n");
      return 2;
    }
  }
  std::string request = cmd;
  for (std::size_t i = 1; i < words.size(); ++i) request += " " + words[i];
  std::string reply, error;
  if (!platform::CtlRequest(socket, request, &reply, &error)) {
    std::fprintf(stderr,
                 "error: %s (is mrd-firmware running with [ctl] socket or "
                 "--ctl-socket there?)\n",
                 error.c_str());
    return 1;
  }
  std::vector<std::string> lines = Split(reply, '\n');
  while (!lines.empty() && lines.back().empty()) lines.pop_back();
  const std::string last = lines.empty() ? "" : lines.back();
  if (!lines.empty()) lines.pop_back();
  if (last.rfind("refused: ", 0) == 0) {
    std::fprintf(stderr, "error: %s\n", last.substr(9).c_str());
    return 2;
  }
  if (last.rfind("ok", 0) != 0) {
    std::fprintf(stderr, "error: %s\n",
                 last.rfind("error: ", 0) == 0 ? last.substr(7).c_str() : last.c_str());
    return 1;
  }
  if (cmd == "list" || cmd == "get") {
    PrintParams(cmd, lines);
  } else if (cmd == "set") {
    PrintSetReply(words[1], last);
  } else {
    std::printf("%s\n", last.substr(3).c_str());  // "saved PATH"
  }
  return std::fflush(stdout) == 0 ? 0 : 1;
}

}  // namespace mrd::firmware
