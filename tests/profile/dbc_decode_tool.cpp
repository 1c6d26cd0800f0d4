// Test tool: decodes payloads with the project's DBC parser and signal codec, for a decoder
// written independently in the test (dbc_independent_test.py) to compare with.
// Usage: dbc_decode_tool FILE.dbc < lines "MESSAGE HEX16"; prints "MESSAGE.SIGNAL VALUE" per
// signal (%.17g), or "error: ..." and exit 2 when the DBC is refused.
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>

#include "mrd/profile/dbc.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: dbc_decode_tool FILE.dbc < payloads\n");
    return 2;
  }
  mrd::profile::Dbc dbc;
  std::string error;
  if (!mrd::profile::LoadDbc(argv[1], &dbc, &error)) {
    std::printf("error: %s\n", error.c_str());
    return 2;
  }
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string name, hex;
    in >> name >> hex;
    const mrd::profile::DbcMessage* m = dbc.Find(name);
    if (m == nullptr || hex.size() != 16) {
      std::printf("error: bad input line '%s'\n", line.c_str());
      return 2;
    }
    std::uint8_t d[8] = {};
    for (int i = 0; i < 8; ++i)
      d[i] = static_cast<std::uint8_t>(std::stoul(hex.substr(2 * i, 2), nullptr, 16));
    for (const auto& s : m->signals) {
      double v = 0;
      (void)mrd::protocol::DecodeSignal(d, s.layout, &v);
      std::printf("%s.%s %.17g\n", m->name.c_str(), s.name.c_str(), v);
    }
  }
  return 0;
}
