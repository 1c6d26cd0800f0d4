// `mrd import` (issue 5, real bench data): the shipped NEES run, synthetic quirky files, and
// every bad-input error.
#include "mrd/host/import.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

constexpr double kPi = std::numbers::pi;
const std::string kNeesFile =
    std::string(MRD_SOURCE_DIR) + "/tests/data/nees-2012-1158/ransim_u.csv";
const std::string kNeesMap = "t=t,x=D,v=V,E=Y,f=F";

ImportOptions Options(const std::string& path, const std::string& map = kNeesMap) {
  ImportOptions o;
  o.in_path = path;
  o.map = ParseImportMap(map);
  return o;
}

// Expects Import to throw InputError whose message contains every fragment.
void ExpectError(const ImportOptions& o, const std::vector<std::string>& fragments) {
  try {
    Import(o);
    FAIL() << "no error for " << o.in_path;
  } catch (const InputError& e) {
    for (const auto& f : fragments) {
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos)
          << "'" << e.what() << "' lacks '" << f << "'";
    }
  }
}

// Synthetic run in the NEES layout: quoted header, trailing commas, fs in the first row only,
// t printed to 5 significant digits. D = 0.5 sin(2 pi 3 t) [cm], V its derivative [cm/s],
// Y = 1 + 0.5 sin(2 pi t) [V], F = 100 sin(2 pi 2 t) [N], A = 0. `last` is appended verbatim.
constexpr double kRate = 3004.8;
double D(double t) { return 0.5 * std::sin(2.0 * kPi * 3.0 * t); }
double V(double t) { return 0.5 * 2.0 * kPi * 3.0 * std::cos(2.0 * kPi * 3.0 * t); }
double Y(double t) { return 1.0 + 0.5 * std::sin(2.0 * kPi * t); }
double F(double t) { return 100.0 * std::sin(2.0 * kPi * 2.0 * t); }

std::string Row(double t, bool first) {
  return fmt::format("{:.5g},0,{:.6g},{:.6g},{},{:.6g},{:.6g},\n", t, D(t), Y(t),
                     first ? "3004.8" : "", V(t), F(t));
}

std::string QuirkyCsv(std::size_t rows, const std::string& last = "") {
  std::string s = "\"t\",\"A\",\"D\",\"Y\",\"fs\",\"V\",\"F\",\n";
  for (std::size_t k = 0; k < rows; ++k) s += Row(static_cast<double>(k) / kRate, k == 0);
  return s + last;
}

// Independent look at the shipped file: line count, lines ending in ',', rows with fs.
struct RawFacts {
  std::size_t lines = 0;
  std::size_t trailing = 0;
  std::size_t fs_filled = 0;
  std::size_t complete_rows = 0;
  double fs = 0.0;
  double t_last = 0.0;  // last complete row
  std::vector<double> t, d;
};

RawFacts ReadRaw(const std::string& path) {
  RawFacts r;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    ++r.lines;
    if (!line.empty() && line.back() == ',') ++r.trailing;
    if (r.lines == 1) continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string item;
    while (std::getline(ss, item, ',')) f.push_back(item);
    if (f.size() < 7) continue;  // std::getline drops the empty field after the last ','
    ++r.complete_rows;
    if (!f[4].empty()) {
      ++r.fs_filled;
      r.fs = std::stod(f[4]);
    }
    r.t_last = std::stod(f[0]);
    r.t.push_back(std::stod(f[0]));
    r.d.push_back(std::stod(f[2]));
  }
  return r;
}

TEST(ImportNeesTest, ShippedFileIsRepairedAndResampledTo1kHz) {
  ASSERT_TRUE(std::filesystem::exists(kNeesFile)) << "missing shipped data: " << kNeesFile;
  const RawFacts raw = ReadRaw(kNeesFile);
  ASSERT_GT(raw.complete_rows, 1000u);

  const ImportResult r = Import(Options(kNeesFile));
  const ImportReport& rep = r.report;
  // The file's last line is incomplete (it has fewer than 7 fields).
  ASSERT_TRUE(rep.dropped_last_line.has_value());
  EXPECT_EQ(*rep.dropped_last_line, raw.lines);
  EXPECT_EQ(rep.data_lines, raw.lines - 1);
  EXPECT_EQ(rep.rows_read, raw.complete_rows);
  EXPECT_EQ(rep.trailing_separators, raw.trailing);  // header + every complete row
  EXPECT_EQ(rep.quoted_names, 7u);
  ASSERT_EQ(rep.sparse_dropped.size(), 1u);
  EXPECT_EQ(rep.sparse_dropped[0].name, "fs");
  EXPECT_EQ(rep.sparse_dropped[0].filled, raw.fs_filled);
  EXPECT_EQ(rep.sparse_dropped[0].first_line, 2u);
  ASSERT_TRUE(rep.stated_rate_hz.has_value());
  EXPECT_DOUBLE_EQ(*rep.stated_rate_hz, raw.fs);
  EXPECT_NEAR(rep.in_rate_hz, raw.fs, 1e-3 * raw.fs);
  EXPECT_EQ(rep.ignored, std::vector<std::string>{"A"});

  // 1 kHz, t from 0 in exact steps, the input's duration.
  EXPECT_EQ(r.names, (std::vector<std::string>{"t", "x", "v", "E", "f"}));
  const auto& t = r.columns[0];
  const auto expected_rows = static_cast<std::size_t>(std::floor(raw.t_last * 1000.0 + 0.5)) + 1;
  EXPECT_NEAR(static_cast<double>(t.size()), static_cast<double>(expected_rows), 1.0);
  EXPECT_EQ(rep.rows_written, t.size());
  for (std::size_t i = 0; i < t.size(); ++i) ASSERT_EQ(t[i], static_cast<double>(i) / 1000.0);

  // The resampled displacement follows the input (100 Hz content, so linear interpolation
  // of the 3 kHz input is a fair reference): RMS difference < 1 % of its RMS.
  double diff2 = 0.0;
  double ref2 = 0.0;
  const auto& x = r.columns[1];
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double u = t[i] * rep.in_rate_hz;
    const auto k = std::min(static_cast<std::size_t>(u), raw.d.size() - 2);
    const double ref = raw.d[k] + (u - static_cast<double>(k)) * (raw.d[k + 1] - raw.d[k]);
    diff2 += (x[i] - ref) * (x[i] - ref);
    ref2 += ref * ref;
  }
  EXPECT_LT(std::sqrt(diff2 / ref2), 0.01);

  const std::string text = FormatImportReport(rep);
  EXPECT_NE(text.find(fmt::format("incomplete last row dropped: line {}", raw.lines)),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("sparse column dropped: 'fs'"), std::string::npos) << text;
  EXPECT_NE(text.find(fmt::format("trailing separators dropped: {} lines", raw.trailing)),
            std::string::npos)
      << text;
}

TEST(ImportNeesTest, CliImportsShippedFileAndReports) {
  ASSERT_TRUE(std::filesystem::exists(kNeesFile)) << "missing shipped data: " << kNeesFile;
  test::TempDir dir;
  const auto out = dir.File("nees.csv");
  const auto r = test::Run(test::Bin("mrd") + " import --in " + kNeesFile + " --map " + kNeesMap +
                           " --rate 1000 --out " + out);
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* s : {"rows:", "input rate:", "output rate: 1000 Hz", "incomplete last row",
                        "sparse column dropped: 'fs'", "trailing separators", "anti-aliasing"}) {
    EXPECT_NE(r.output.find(s), std::string::npos) << "lacks '" << s << "':\n" << r.output;
  }
  const DataSet ds = ReadCsv(out, std::vector<std::string>{"x", "v", "E", "f"});  // validates
  EXPECT_EQ(ds.names, (std::vector<std::string>{"t", "x", "v", "E", "f"}));
  EXPECT_NEAR(ds.dt, 1e-3, 1e-12);
}

TEST(ImportTest, SyntheticQuirkyFileMatchesItsSignals) {
  test::TempDir dir;
  const std::size_t rows = 6000;                                           // ~2 s
  const auto path = dir.Write("q.csv", QuirkyCsv(rows, "1.9,12.5,-0.1"));  // truncated row
  const ImportResult r = Import(Options(path));
  EXPECT_EQ(r.report.rows_read, rows);
  EXPECT_EQ(r.report.trailing_separators, rows + 1);
  ASSERT_TRUE(r.report.dropped_last_line.has_value());
  EXPECT_EQ(*r.report.dropped_last_line, rows + 2);
  EXPECT_NEAR(r.report.in_rate_hz, kRate, 1e-3);
  const auto& t = r.columns[0];
  double worst[5] = {};
  for (std::size_t i = 0; i < t.size(); ++i) {
    worst[1] = std::max(worst[1], std::fabs(r.columns[1][i] - D(t[i])));
    worst[2] = std::max(worst[2], std::fabs(r.columns[2][i] - V(t[i])));
    worst[3] = std::max(worst[3], std::fabs(r.columns[3][i] - Y(t[i])));
    worst[4] = std::max(worst[4], std::fabs(r.columns[4][i] - F(t[i])));
  }
  // Printed to 6 digits, t to 5: errors of a few 1e-5 relative; edges included.
  EXPECT_LT(worst[1], 1e-4);  // of 0.5 cm
  EXPECT_LT(worst[2], 1e-3);  // of 9.4 cm/s
  EXPECT_LT(worst[3], 1e-4);  // of 1.5 V
  EXPECT_LT(worst[4], 2e-2);  // of 100 N
}

TEST(ImportTest, DerivedVelocityMatchesTheDerivative) {
  test::TempDir dir;
  const auto path = dir.Write("q.csv", QuirkyCsv(6000));
  ImportOptions o = Options(path, "t=t,x=D,E=Y,f=F,v_file=V");
  o.derive_velocity = true;
  const ImportResult r = Import(o);
  ASSERT_EQ(r.names, (std::vector<std::string>{"t", "x", "v", "E", "f", "v_file"}));
  EXPECT_FALSE(r.report.dropped_last_line.has_value());
  double worst = 0.0;
  for (std::size_t i = 0; i < r.columns[0].size(); ++i) {
    const double t = r.columns[0][i];
    if (t < 0.1 || t > r.columns[0].back() - 0.1) continue;  // filter edges
    worst = std::max(worst, std::fabs(r.columns[2][i] - V(t)));
  }
  EXPECT_LT(worst, 0.01 * 3.0 * kPi);  // 1 % of the 9.4 cm/s peak
}

TEST(ImportTest, ScaleMultipliesMappedColumns) {
  test::TempDir dir;
  const auto path = dir.Write("q.csv", QuirkyCsv(3000));
  ImportOptions plain = Options(path);
  ImportOptions scaled = Options(path);
  scaled.scale = ParseImportScale("x=10,f=0.001");
  const ImportResult a = Import(plain);
  const ImportResult b = Import(scaled);
  ASSERT_EQ(a.columns[0].size(), b.columns[0].size());
  for (std::size_t i = 0; i < a.columns[0].size(); i += 97) {
    EXPECT_NEAR(b.columns[1][i], 10.0 * a.columns[1][i], 1e-12);
    EXPECT_NEAR(b.columns[4][i], 0.001 * a.columns[4][i], 1e-12);
    EXPECT_EQ(b.columns[3][i], a.columns[3][i]);
  }
}

TEST(ImportTest, LastRowWithoutTrailingSeparatorIsDroppedAsTruncated) {
  test::TempDir dir;
  const std::string row = Row(3000.0 / kRate, false);
  const auto path = dir.Write("q.csv", QuirkyCsv(3000, row.substr(0, row.size() - 5)));
  const ImportResult r = Import(Options(path));
  EXPECT_EQ(r.report.rows_read, 3000u);
  ASSERT_TRUE(r.report.dropped_last_line.has_value());
  EXPECT_EQ(*r.report.dropped_last_line, 3002u);
  EXPECT_NE(r.report.dropped_last_reason.find("truncated"), std::string::npos);
}

TEST(ImportTest, LastRowWithTruncatedExponentIsDropped) {
  test::TempDir dir;
  const auto path = dir.Write("q.csv", QuirkyCsv(3000, "0.99841,0,0.1,1.0,,0.3,-7.5e,\n"));
  const ImportResult r = Import(Options(path));
  EXPECT_EQ(r.report.rows_read, 3000u);
  ASSERT_TRUE(r.report.dropped_last_line.has_value());
  EXPECT_NE(r.report.dropped_last_reason.find("'F'"), std::string::npos);
}

TEST(ImportTest, NonNumericMidFileNamesLineAndColumn) {
  test::TempDir dir;
  std::string text = QuirkyCsv(3000);
  const std::size_t line5 = [&] {  // start of file line 5
    std::size_t pos = 0;
    for (int i = 0; i < 4; ++i) pos = text.find('\n', pos) + 1;
    return pos;
  }();
  const std::size_t d_start = text.find(',', text.find(',', line5) + 1) + 1;  // field 3 (D)
  text.replace(d_start, text.find(',', d_start) - d_start, "0.1x");
  const auto path = dir.Write("bad.csv", text);
  ExpectError(Options(path), {"bad.csv:5", "'D'", "not a number", "0.1x"});
}

TEST(ImportTest, NonFiniteValueIsAnError) {
  test::TempDir dir;
  for (const char* bad : {"inf", "nan", "1e999"}) {
    std::string text = "t,D,Y,V,F\n";
    for (int k = 0; k < 200; ++k) {
      text += fmt::format("{:g},{},2,3,4\n", k * 1e-3, k == 40 ? bad : "1");
    }
    const auto path = dir.Write("inf.csv", text);
    ExpectError(Options(path), {"inf.csv:42", "'D'", "non-finite"});
  }
}

TEST(ImportTest, UnknownColumnInMapIsAnError) {
  test::TempDir dir;
  const auto path = dir.Write("q.csv", QuirkyCsv(100));
  ExpectError(Options(path, "t=t,x=Disp,v=V,E=Y,f=F"), {"q.csv:1", "'Disp'", "D,Y"});
}

TEST(ImportTest, NonIncreasingTimeNamesTheLine) {
  test::TempDir dir;
  std::string text = "\"t\",\"D\",\"Y\",\"V\",\"F\",\n";
  for (int k = 0; k < 200; ++k) {
    const double t = (k == 150 ? 149 : k) * 1e-3;
    text += fmt::format("{:g},1,2,3,4,\n", t);
  }
  const auto path = dir.Write("t.csv", text);
  ExpectError(Options(path), {"t.csv:152", "not increasing"});
}

TEST(ImportTest, GapInTimeNamesTheLine) {
  test::TempDir dir;
  std::string text = "t,D,Y,V,F\n";
  for (int k = 0; k < 400; ++k) {
    text += fmt::format("{:g},1,2,3,4\n", (k < 300 ? k : k + 1) * 1e-3);
  }
  const auto path = dir.Write("gap.csv", text);
  ExpectError(Options(path), {"gap.csv:302", "non-uniform"});
}

TEST(ImportTest, SmallJitterWithinToleranceIsAccepted) {
  test::TempDir dir;
  std::string text = "t,D,Y,V,F\n";
  for (int k = 0; k < 400; ++k) {
    text += fmt::format("{:.9f},1,2,3,4\n", k * 1e-3 + (k % 2 ? 5e-6 : -5e-6));  // 0.5 %
  }
  const auto path = dir.Write("jitter.csv", text);
  EXPECT_NO_THROW(Import(Options(path)));
  ImportOptions strict = Options(path);
  strict.max_jitter = 0.001;
  ExpectError(strict, {"jitter.csv:3", "non-uniform"});
}

TEST(ImportTest, WrongFieldCountMidFileIsAnError) {
  test::TempDir dir;
  std::string text = "t,D,Y,V,F\n";
  for (int k = 0; k < 200; ++k)
    text += fmt::format("{:g},1,2,3{}\n", k * 1e-3, k == 50 ? "" : ",4");
  const auto path = dir.Write("w.csv", text);
  ExpectError(Options(path), {"w.csv:52", "expected 5 fields, found 4"});
}

TEST(ImportTest, BlankLineMidFileIsAnError) {
  test::TempDir dir;
  std::string text = "t,D,Y,V,F\n";
  for (int k = 0; k < 200; ++k) text += k == 50 ? "\n" : fmt::format("{:g},1,2,3,4\n", k * 1e-3);
  const auto path = dir.Write("b.csv", text);
  ExpectError(Options(path), {"b.csv:52", "blank line"});
}

TEST(ImportTest, ValueAfterTrailingSeparatorIsAnError) {
  test::TempDir dir;
  std::string text = QuirkyCsv(200);
  const std::size_t eol = text.find('\n', text.find('\n', text.find('\n') + 1) + 1);  // line 3
  text.insert(eol, "9");
  const auto path = dir.Write("v.csv", text);
  ExpectError(Options(path), {"v.csv:3", "value '9' after the last named column"});
}

TEST(ImportTest, MappedSparseColumnIsAnError) {
  test::TempDir dir;
  const auto path = dir.Write("q.csv", QuirkyCsv(200));
  ExpectError(Options(path, "t=t,x=D,v=V,E=Y,f=F,rate=fs"), {"q.csv:3", "'fs'", "no value"});
}

TEST(ImportTest, StatedRateThatDisagreesIsAnError) {
  test::TempDir dir;
  std::string text = QuirkyCsv(3000);
  text.replace(text.find("3004.8"), 6, "3000.0");
  const auto path = dir.Write("q.csv", text);
  ExpectError(Options(path), {"q.csv:2", "'fs' states 3000 Hz"});
  ImportOptions unchecked = Options(path);
  unchecked.rate_column.clear();
  EXPECT_NO_THROW(Import(unchecked));
}

TEST(ImportTest, OptionErrorsNameTheFlag) {
  test::TempDir dir;
  const auto path = dir.Write("q.csv", QuirkyCsv(200));
  EXPECT_THROW(ParseImportMap("t=t,x"), InputError);
  EXPECT_THROW(ParseImportMap("t=t,t=D"), InputError);
  EXPECT_THROW(ParseImportScale("x=0"), InputError);
  EXPECT_THROW(ParseImportScale("x=abc"), InputError);
  ExpectError(Options(path, "t=t,x=D,v=V,f=F"), {"--map lacks 'E'"});
  ImportOptions both = Options(path);
  both.derive_velocity = true;
  ExpectError(both, {"--derive-velocity"});
  ImportOptions bad_scale = Options(path);
  bad_scale.scale = {{"q", 2.0}};
  ExpectError(bad_scale, {"--scale q"});
}

TEST(ImportTest, CliBadInputExits2AndWritesNothing) {
  test::TempDir dir;
  const auto path = dir.Write("t.csv", "t,D,Y,V,F\n0,1,2,3,4\n0.001,1,x,3,4\n0.002,1,2,3,4\n");
  const auto out = dir.File("out.csv");
  const auto r =
      test::Run(test::Bin("mrd") + " import --in " + path + " --map " + kNeesMap + " --out " + out);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("t.csv:3"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace mrd::host
