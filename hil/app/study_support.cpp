// Helpers of `mrd-hil study` (study_support.hpp).
#include "study_support.hpp"

#include <cstdio>
#include <filesystem>
#include <sstream>

#include "mrd/hil/plants/ride.hpp"
#include "mrd/sim/iso8608_road.hpp"
#include "table_check.hpp"

namespace mrd::hil::study {

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::string item;
  std::stringstream ss(s);
  while (std::getline(ss, item, ',')) out.push_back(item);
  if (!s.empty() && s.back() == ',') out.push_back("");
  return out;
}

std::string Num(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

std::string Signed(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%+.1f %%", v);
  return buf;
}

// Text inside a gnuplot single-quoted string: a quote doubled.
std::string GnuplotQuotable(const std::string& v) {
  std::string out;
  for (const char c : v) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out;
}

// CSV text of one cell: quoted when it holds a comma or a quote.
std::string CsvCell(const std::string& v) {
  if (v.find_first_of(",\"\n") == std::string::npos) return v;
  std::string q = "\"";
  for (const char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

int Bad(const std::string& what) {
  std::fprintf(stderr, "error: %s\n", what.c_str());
  return kBadInput;
}

int ParseClassesAndSpeeds(const StudyOptions& o, std::vector<char>* classes,
                          std::vector<double>* speeds) {
  for (const std::string& c : Split(o.classes)) {
    RoadClass rc{};
    if (c.size() != 1 || !RoadClassFromChar(c[0], &rc)) {
      return Bad("--classes '" + o.classes + "': '" + c + "' is not a road class A .. H");
    }
    const char upper = static_cast<char>(c[0] & ~0x20);
    for (const char k : (*classes)) {
      if (k == upper) return Bad("--classes '" + o.classes + "': names " + c + " twice");
    }
    classes->push_back(upper);
  }
  const auto speed = [](double x) { return x > 0.0 && x <= 100.0; };
  if (const int rc = ParseNumbers("--speeds", o.speeds, speed, "a speed in (0, 100] m/s", speeds);
      rc != 0) {
    return rc;
  }
  if (classes->empty()) return Bad("--classes: no road class given");
  if (speeds->empty()) return Bad("--speeds: no speed given");
  return 0;
}

int MakeOutDir(const StudyOptions& o, std::string* dir) {
  *dir =
      o.out_dir.empty() ? "study-" + std::filesystem::path(o.scenario).stem().string() : o.out_dir;
  std::error_code ec;
  std::filesystem::create_directories(*dir, ec);
  if (ec || !std::filesystem::is_directory(*dir)) {
    std::fprintf(stderr, "error: --out %s: cannot create the directory\n", dir->c_str());
    return 1;
  }
  return 0;
}

int LoadBaseInputs(const StudyOptions& o, BaseInputs* in) {
  Scenario& base = in->base;
  if (!LoadRunTable(base.table_file, &in->table)) return kBadInput;
  in->table_label = TableLabel(base.table_file, in->table);
  in->plant_label = PlantLabel(base);
  if (o.duration_s >= 0.0) {
    if (!(o.duration_s > base.ride_settle_s) || o.duration_s > 1e5) {
      return Bad("--duration " + Num(o.duration_s) + ": must be longer than the settle time " +
                 Num(base.ride_settle_s) + " s (and at most 1e5 s)");
    }
    base.duration_s = o.duration_s;
  }
  in->step = o.passive_step_v >= 0.0 ? o.passive_step_v : base.passive_step_v;
  std::string error;
  if (!GridVoltages(0.0, base.e_max, in->step, &in->volts, &error)) {
    return Bad("--passive-step " + Num(in->step) + ": " + error);
  }
  if (in->volts.size() > 10000) {
    return Bad("--passive-step " + Num(in->step) + ": more than 10000 points");
  }
  return 0;
}

}  // namespace mrd::hil::study
