#pragma once
// Command-line number checks for the host programs (CLI11). CLI::Range lets "nan" through:
// every comparison with NaN is false. FiniteRange is CLI::Range that also refuses NaN and
// infinities; Finite refuses them on an option with no range. Apps only (needs CLI11).

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

namespace mrd::cli {

// "" when text is not NaN or infinite (a non-number is left to the option's own conversion).
inline std::string FiniteOrWhy(const std::string& text) {
  const double v = std::strtod(text.c_str(), nullptr);
  if (std::isfinite(v)) return {};
  return "Value " + text + " is not a finite number";
}

class FiniteRange : public CLI::Range {
 public:
  template <typename T>
  FiniteRange(T min, T max) : CLI::Range(min, max) {
    auto range = func_;
    std::ostringstream bounds;  // as given (CLI11 says "0.010000 to 24.000000")
    bounds << "[" << min << ", " << max << "]";
    func_ = [range, b = bounds.str()](std::string& text) {
      std::string why = FiniteOrWhy(text);
      if (!why.empty()) return why;
      why = range(text);
      return why.empty() || why.find(" not in range ") == std::string::npos
                 ? why
                 : "Value " + text + " not in " + b;
    };
  }
};

inline const CLI::Validator Finite([](std::string& text) { return FiniteOrWhy(text); }, "",
                                   "Finite");

}  // namespace mrd::cli
