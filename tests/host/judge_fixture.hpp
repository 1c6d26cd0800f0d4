#pragma once
// Fixtures of the model-judging tests: a linear ARX damper-like model written as a model file
// (no identification run), and data files generated from it.
//   f_n(k) = a f_n(k-1) + b E_n(k) + c v_n(k) + noise_n(k),  normalised by the model's
//   channel scales f 1000 N, E 2.25 V, v 15 cm/s; envelope E [0, 2.25] V, v [-15, 15] cm/s.

#include <cmath>
#include <string>
#include <vector>

#include "mrd/host/csv.hpp"
#include "mrd/host/model_file.hpp"
#include "sem_test_util.hpp"

namespace mrd::test {

inline constexpr const char* kArxSpec = R"(output = "f"
[[regressor]]
name = "y"
signal = "f"
powers = [1]
delays = [1]
[[regressor]]
name = "e"
signal = "E"
powers = [1]
delays = [0]
[[regressor]]
name = "u"
signal = "v"
powers = [1]
delays = [0]
[cost]
weighting = "mse"
)";

// Model file of f_n(k) = a f_n(k-1) + b E_n(k) + c v_n(k).
inline void WriteArxModel(const std::string& path, double a, double b, double c,
                          bool relative = false) {
  host::ModelFile m;
  std::string spec = kArxSpec;
  if (relative) spec.replace(spec.find("weighting = \"mse\""), 17, "weighting = \"relative\"");
  m.spec = host::ParseSemSpec(spec, "arx.toml");
  m.channels = {{"f", 0.0, 1000.0, true, -1000.0, 1000.0},
                {"E", 0.0, 2.25, true, 0.0, 2.25},
                {"v", 0.0, 15.0, true, -15.0, 15.0}};
  host::SemIteration it;
  it.iteration = 1;
  it.terms = {host::SemTerm{{{0, 1, 1}}}, host::SemTerm{{{1, 0, 1}}}, host::SemTerm{{{2, 0, 1}}}};
  it.coefficients = {a, b, c};
  it.j = 0.01;
  m.iterations = {it};
  m.selected = 1;
  m.selection_rule = "test fixture";
  host::SaveModelFile(m, path);
}

// Data t, x, v, E, f of the ARX system above (a 0.9, b 0.05, c 0.08) driven by E uniform in
// [0, 2.25] V and v = v_peak sin(2 pi 1.3 t) + random part; equation noise of standard
// deviation noise (normalised) enters f(k) (so the one-step residual of the exact model is
// white). rows at 1 ms.
inline void WriteArxData(const std::string& path, double v_peak, double noise, std::uint64_t seed,
                         std::size_t rows = 8000) {
  Gauss g(seed);
  std::vector<double> t(rows), x(rows), v(rows), E(rows), f(rows);
  double fn = 0.0;
  for (std::size_t k = 0; k < rows; ++k) {
    t[k] = 1e-3 * static_cast<double>(k);
    v[k] = v_peak * (0.9 * std::sin(2.0 * M_PI * 1.3 * t[k]) + 0.1 * std::tanh(g()));
    x[k] = v_peak / (2.0 * M_PI * 1.3) * -std::cos(2.0 * M_PI * 1.3 * t[k]);
    E[k] = 2.25 * g.Uniform();
    fn = 0.9 * fn + 0.05 * E[k] / 2.25 + 0.08 * v[k] / 15.0 + noise * g();
    f[k] = 1000.0 * fn;
  }
  host::WriteCsv(path, {"t", "x", "v", "E", "f"}, {t, x, v, E, f});
}

}  // namespace mrd::test
