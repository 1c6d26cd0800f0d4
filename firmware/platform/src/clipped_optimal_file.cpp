// Compiled with exceptions (toml++); every exception is caught here.
#include "mrd/firmware/platform/clipped_optimal_file.hpp"

#include <toml++/toml.h>

#include <cmath>
#include <cstdint>
#include <cstring>

#include "mrd/common/input_file.hpp"

namespace mrd::firmware::platform {
namespace {

constexpr int kN = ClippedOptimalGains::kStates;
constexpr int kM = ClippedOptimalGains::kOutputs;

struct ArrayKey {
  const char* name;
  double* out;
  int count;
};

std::string At(const std::string& source, const toml::node& n) {
  return source + ":" + std::to_string(n.source().begin.line) + ": ";
}

}  // namespace

bool ClippedObserverStable(const ClippedOptimalGains& g) {
  // E = ad - l cy, then squared 20 times, rescaled so it cannot overflow: the log of the
  // scale accumulates the growth. Stable: ||E^(2^20)|| (log) far below 0.
  double e[kN * kN];
  for (int r = 0; r < kN; ++r) {
    for (int c = 0; c < kN; ++c) {
      double v = g.ad[r * kN + c];
      for (int j = 0; j < kM; ++j) v -= g.l[r * kM + j] * g.cy[j * kN + c];
      e[r * kN + c] = v;
    }
  }
  double log_norm = 0.0;  // log of the factor taken out of E^(2^i)
  for (int i = 0; i < 20; ++i) {
    double sq[kN * kN] = {};
    for (int r = 0; r < kN; ++r) {
      for (int c = 0; c < kN; ++c) {
        for (int j = 0; j < kN; ++j) sq[r * kN + c] += e[r * kN + j] * e[j * kN + c];
      }
    }
    log_norm *= 2.0;
    double m = 0.0;
    for (double v : sq) m = std::fmax(m, std::fabs(v));
    if (!std::isfinite(m)) return false;
    if (m == 0.0) return true;  // nilpotent
    for (int k = 0; k < kN * kN; ++k) e[k] = sq[k] / m;
    log_norm += std::log(m);
  }
  // ||E^(2^20)|| ~ exp(log_norm): a spectral radius rho gives 2^20 log(rho).
  return log_norm < -10.0;
}

bool ParseClippedOptimalGains(std::string_view text, const std::string& source_raw,
                              ClippedOptimalGains* gains, std::string* error) {
  try {
    const std::string source = Printable(source_raw);
    try {
      const toml::table root = toml::parse(text, source_raw);
      const char* kWhere = "[control.clipped_optimal]";
      const toml::table* control = nullptr;
      for (const auto& [name, node] : root) {
        if (name.str() != "control" || !node.is_table()) {
          *error = At(source, node) + "unexpected '" + Printable(name.str()) +
                   "': the file holds only the table " + kWhere +
                   " (the file mrd-structure design --out writes)";
          return false;
        }
        control = node.as_table();
      }
      if (control == nullptr) {
        *error =
            source + ":1: no table " + kWhere + " (the file mrd-structure design --out writes)";
        return false;
      }
      const toml::table* tbl = nullptr;
      for (const auto& [name, node] : *control) {
        if (name.str() != "clipped_optimal" || !node.is_table()) {
          *error = At(source, node) + "unexpected 'control." + Printable(name.str()) +
                   "': the file holds only the table " + kWhere;
          return false;
        }
        tbl = node.as_table();
      }
      if (tbl == nullptr) {
        *error = At(source, *control) + "no table " + kWhere;
        return false;
      }
      ClippedOptimalGains g;
      // dampers (optional, 1): the force inputs m; bd (kN x m), dy (kM x m) and k (m x kN)
      // hold m numbers per row, row-major.
      if (const toml::node* n = tbl->get("dampers")) {
        const auto v = n->value_exact<std::int64_t>();
        if (!v || *v < 1 || *v > ClippedOptimalGains::kMaxDampers) {
          *error = At(source, *n) + "'dampers' must be an integer in [1, " +
                   std::to_string(ClippedOptimalGains::kMaxDampers) + "] (the force inputs)";
          return false;
        }
        g.dampers = static_cast<int>(*v);
      }
      const int m = g.dampers;
      const ArrayKey arrays[] = {{"ad", g.ad, kN * kN}, {"bd", g.bd, kN * m}, {"cy", g.cy, kM * kN},
                                 {"dy", g.dy, kM * m},  {"l", g.l, kN * kM},  {"k", g.k, m * kN}};
      for (const auto& [name, node] : *tbl) {
        bool known = name.str() == "v_max" || name.str() == "v_min" || name.str() == "dampers";
        for (const ArrayKey& a : arrays) known = known || name.str() == a.name;
        if (!known) {
          *error = At(source, node) + "unknown key '" + Printable(name.str()) + "' in " + kWhere +
                   " (dampers, ad, bd, cy, dy, l, k, v_max, v_min)";
          return false;
        }
      }
      for (const ArrayKey& a : arrays) {
        const toml::node* n = tbl->get(a.name);
        if (n == nullptr) {
          *error = At(source, *tbl) + kWhere + " has no '" + a.name + "' (" +
                   std::to_string(a.count) + " numbers)";
          return false;
        }
        const toml::array* arr = n->as_array();
        if (arr == nullptr || static_cast<int>(arr->size()) != a.count) {
          *error = At(source, *n) + "'" + a.name + "' must be a list of " +
                   std::to_string(a.count) + " numbers" +
                   (arr != nullptr ? " (has " + std::to_string(arr->size()) + ")" : "") +
                   (m > 1 ? " for dampers = " + std::to_string(m) : "");
          return false;
        }
        for (int i = 0; i < a.count; ++i) {
          const toml::node& e = *arr->get(static_cast<std::size_t>(i));
          const auto v = e.value<double>();
          if (!v || !std::isfinite(*v)) {
            *error = At(source, e) + "'" + a.name + "' element " + std::to_string(i + 1) +
                     " must be a finite number";
            return false;
          }
          a.out[i] = *v;
        }
      }
      for (const auto& [key, out] : {std::pair<const char*, double*>{"v_max", &g.v_max},
                                     std::pair<const char*, double*>{"v_min", &g.v_min}}) {
        const toml::node* n = tbl->get(key);
        if (n == nullptr) {
          *error = At(source, *tbl) + kWhere + " has no '" + key + "' [V]";
          return false;
        }
        const auto v = n->value<double>();
        if (!v || !std::isfinite(*v) || std::fabs(*v) > 1e3) {
          *error = At(source, *n) + "'" + key + "' must be a number in [-1000, 1000] [V]";
          return false;
        }
        *out = *v;
      }
      if (g.v_min > g.v_max) {
        *error = At(source, *tbl->get("v_min")) + "v_min must not exceed v_max";
        return false;
      }
      if (!ClippedObserverStable(g)) {
        *error = At(source, *tbl->get("l")) +
                 "the observer is unstable: ad - l cy has an eigenvalue on or outside the unit "
                 "circle (gains of another design or period?)";
        return false;
      }
      *gains = g;
      return true;
    } catch (const toml::parse_error& e) {
      *error =
          source + ":" + std::to_string(e.source().begin.line) + ": " + Printable(e.description());
      return false;
    }
  } catch (const std::exception& e) {  // std::bad_alloc
    *error = Printable(source_raw) + ": " + e.what();
    return false;
  }
}

bool LoadClippedOptimalGains(const std::string& path, ClippedOptimalGains* gains,
                             std::string* error) {
  try {
    std::string text;
    if (!ReadInputFile(path, kMaxGainsBytes, &text, error)) return false;
    return ParseClippedOptimalGains(text, path, gains, error);
  } catch (const std::exception& e) {  // std::bad_alloc
    *error = Printable(path) + ": " + e.what();
    return false;
  }
}

}  // namespace mrd::firmware::platform
