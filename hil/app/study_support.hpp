#pragma once
// Helpers of `mrd-hil study` shared by the quarter-car and the full-car study: list parsing,
// number formatting, CSV and gnuplot quoting, the bad-input exit, the output directory.

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "mrd/common/table.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "study_command.hpp"

namespace mrd::hil::study {

inline constexpr int kBadInput = 2;

// Comma-separated items (a trailing comma gives an empty last item).
std::vector<std::string> Split(const std::string& s);
// %.*g of v.
std::string Num(double v, int digits = 4);
// "+1.2 %".
std::string Signed(double v);
// Text inside a gnuplot single-quoted string: a quote doubled.
std::string GnuplotQuotable(const std::string& v);
// CSV text of one cell: quoted when it holds a comma or a quote.
std::string CsvCell(const std::string& v);
// "error: WHAT" on stderr; kBadInput.
int Bad(const std::string& what);
// --classes (upper case, distinct) and --speeds; 0, or the exit code after the message.
int ParseClassesAndSpeeds(const StudyOptions& o, std::vector<char>* classes,
                          std::vector<double>* speeds);
// The output directory (--out, default study-NAME after the scenario), created; 0, or 1 after
// the message when it cannot be.
int MakeOutDir(const StudyOptions& o, std::string* dir);

// What both studies take from the base scenario and the common flags.
struct BaseInputs {
  Scenario base;
  CoefficientTable table;     // the scenario's [firmware] table, or the compiled-in one
  std::string table_label;    // its path and CRC (TableLabel)
  std::string plant_label;    // PlantLabel
  double step = 0.0;          // the passive grid's step [V]
  std::vector<double> volts;  // the passive grid, 0 to e_max [V]
};
// With in->base loaded: the table and the labels, --duration (longer than the settle time,
// at most 1e5 s) into base.duration_s, the passive grid at --passive-step (default the
// scenario's; at most 10000 points). 0, or the exit code after the message.
int LoadBaseInputs(const StudyOptions& o, BaseInputs* in);

// A comma-separated list of distinct numbers, each accepted by `in_range`; `what` names one in
// the message ("a speed in (0, 100] m/s"). 0, or the exit code after the message naming flag.
template <typename InRange>
int ParseNumbers(const char* flag, const std::string& text, const InRange& in_range,
                 const char* what, std::vector<double>* out) {
  for (const std::string& v : Split(text)) {
    char* end = nullptr;
    const double x = std::strtod(v.c_str(), &end);
    if (v.empty() || end != v.c_str() + v.size() || !in_range(x)) {
      return Bad(std::string(flag) + " '" + text + "': '" + v + "' is not " + what);
    }
    for (const double k : *out) {
      if (k == x) return Bad(std::string(flag) + " '" + text + "': names " + v + " twice");
    }
    out->push_back(x);
  }
  return 0;
}

}  // namespace mrd::hil::study
