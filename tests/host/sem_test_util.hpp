#pragma once
// Helpers for SEM tests: in-memory data sets, reference damper data, known NARX systems.

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "mrd/host/csv.hpp"
#include "mrd/host/params_file.hpp"
#include "mrd/host/profiles.hpp"

namespace mrd::test {

inline host::DataSet MakeDataSet(const std::string& name, std::vector<std::string> names,
                                 std::vector<std::vector<double>> cols) {
  host::DataSet d;
  d.path = name;
  const std::size_t n = cols.front().size();
  std::vector<double> t(n);
  for (std::size_t k = 0; k < n; ++k) t[k] = 1e-3 * static_cast<double>(k);
  d.names = {"t"};
  d.columns = {t};
  for (std::size_t i = 0; i < names.size(); ++i) {
    d.names.push_back(names[i]);
    d.columns.push_back(cols[i]);
  }
  d.dt = 1e-3;
  return d;
}

// Reference damper data of a profile (the same as `mrd generate`), optionally the first
// `rows` rows only.
inline host::DataSet DamperData(const std::string& profile, std::size_t rows = 0,
                                std::uint64_t seed = 1) {
  const SpencerParams p = host::SpencerPreset("paper");
  const host::Excitation ex = host::MakeExcitation(profile, seed);
  const std::vector<double> f = SimulateReferenceDamper(p, ex, 100);
  host::DataSet d = MakeDataSet(profile, {"x", "v", "E", "f"}, {ex.x, ex.v, ex.E, f});
  if (rows > 0 && rows < d.rows()) {
    for (auto& c : d.columns) c.resize(rows);
  }
  return d;
}

// A damper spec whose command enters through a low-pass filter (as host/specs/nees.toml),
// with a constant and MSE weighting; small enough to identify in well under a second.
inline constexpr const char* kLowPassSpec = R"(output = "f"
[[regressor]]
name = "y"
signal = "f"
powers = [1, 2]
delays = [1]
[[regressor]]
name = "e"
signal = "E"
transform = "low_pass"
tau = 5.0
powers = [1, 2]
delays = [0, 2]
[[regressor]]
name = "a"
signal = "v"
transform = "abs_pow"
exponent = 0.2
powers = [1, 2, 3]
[[regressor]]
name = "s"
signal = "v"
transform = "sign"
powers = [1]
[limits]
constant = true
[cost]
weighting = "mse"
)";

// Standard normal deviates by Box-Muller on a fixed engine (portable across libraries).
class Gauss {
 public:
  explicit Gauss(std::uint64_t seed) : rng_(seed) {}
  double Uniform() { return (static_cast<double>(rng_() >> 11) + 0.5) * 0x1.0p-53; }
  double operator()() {
    const double u1 = Uniform(), u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }

 private:
  std::mt19937_64 rng_;
};

}  // namespace mrd::test
