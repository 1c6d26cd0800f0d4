#include "mrd/hil/plants/replay.hpp"

#include <cmath>
#include <fstream>

#include "mrd/common/input_file.hpp"

namespace mrd::hil {

bool LoadReplay(const std::string& path, bool open_loop, const std::string& demand_column,
                Trace* trace, ReplayRun* run, std::string* error) {
  // The header first, so that a missing column is named before any row is read.
  std::string text;
  if (!ReadInputFile(path, std::uint64_t{256} << 20, &text, error)) return false;
  const std::string header = text.substr(0, text.find('\n'));
  std::vector<std::string> names;
  for (std::size_t a = 0; a <= header.size();) {
    std::size_t b = header.find(',', a);
    if (b == std::string::npos) b = header.size();
    std::string n = header.substr(a, b - a);
    while (!n.empty() && (n.back() == '\r' || n.back() == ' ')) n.pop_back();
    while (!n.empty() && n.front() == ' ') n.erase(n.begin());
    names.push_back(n);
    a = b + 1;
  }
  std::string missing;
  for (const std::string& need :
       {std::string("x"), std::string("v"), std::string("E"), demand_column}) {
    bool found = false;
    for (const std::string& n : names) found = found || n == need;
    if (!found && missing.find("'" + need + "'") == std::string::npos) {
      missing += (missing.empty() ? "'" : ", '") + need + "'";
    }
  }
  if (!missing.empty()) {
    *error = Printable(path) + ":1: a replay file needs columns x, v, E and " +
             Printable(demand_column) + " (measured motion, command and force); missing " +
             Printable(missing);
    return false;
  }
  Trace with_f, with_e;
  if (!LoadTrace(path, demand_column, &with_f, error)) return false;
  if (!LoadTrace(path, "E", &with_e, error)) return false;
  run->f = with_f.demand;
  if (open_loop) {
    // Step k (row k -> k + 1) is driven with E of row k + 1, as `mrd generate` and `mrd
    // fit-spencer` hold it; the last row holds. [V] -> [mV], the open-loop law's unit.
    std::vector<double>& e = with_e.demand;
    for (std::size_t k = 0; k < e.size(); ++k) e[k] = 1e3 * e[std::min(k + 1, e.size() - 1)];
    with_f.demand = std::move(e);
  }
  *trace = std::move(with_f);
  return true;
}

}  // namespace mrd::hil
