// Published figures beside the structure study (mrd/structure/reference.hpp): the reference
// file's refusals with FILE:LINE, the per-cell differences against a tolerance, and whether
// clipped-optimal changes each peak the way the reference does.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "mrd/structure/reference.hpp"

namespace {

using mrd::structure::Case;
using mrd::structure::Reference;
using mrd::structure::Response;

std::string TempFile(const std::string& name, const std::string& text) {
  char dir[] = "/tmp/mrd-reference-XXXXXX";
  const std::string path = std::string(mkdtemp(dir) != nullptr ? dir : "/tmp") + "/" + name;
  std::ofstream(path) << text;
  return path;
}

constexpr char kHeader[] = "case,x1,x2,x3,d1,d2,d3,xa1,xa2,xa3,f\n";

// A response whose every peak is `scale` times its column number (1-based).
Response Uniform(Case which, double scale) {
  Response r;
  r.which = which;
  for (int i = 0; i < 3; ++i) {
    r.peak_x_cm[i] = scale * (i + 1);
    r.peak_d_cm[i] = scale * (i + 4);
    r.peak_xa_cm_s2[i] = scale * (i + 7);
  }
  r.peak_force_n = scale * 10;
  return r;
}

std::string Row(const char* name, double scale) {
  std::string s = name;
  for (int j = 1; j <= 10; ++j) {
    s += ',';
    s += std::to_string(scale * j);
  }
  s += '\n';
  return s;
}

TEST(StructureReferenceTest, ReadsTheTableWithItsSourceAndEmptyCells) {
  const std::string path =
      TempFile("ref.csv", std::string("# Some et al., Table 2\n# second comment\n") + kHeader +
                              Row("passive-on", 1.0) + "clipped-optimal,1,2,3,4,5,6,7,8,9,\n");
  Reference ref;
  std::string error;
  ASSERT_TRUE(mrd::structure::LoadReference(path, &ref, &error)) << error;
  EXPECT_EQ(ref.source, "Some et al., Table 2");
  ASSERT_EQ(ref.rows.size(), 2u);
  EXPECT_EQ(ref.rows[0].which, Case::kPassiveOn);
  EXPECT_EQ(ref.rows[1].which, Case::kClippedOptimal);
  EXPECT_TRUE(ref.rows[1].given[8]);
  EXPECT_FALSE(ref.rows[1].given[9]) << "an empty cell is not published";
  EXPECT_DOUBLE_EQ(ref.rows[0].value[6], 7.0);
}

TEST(StructureReferenceTest, BadFilesAreRefusedWithTheLine) {
  struct Bad {
    std::string text;
    std::string message;
  };
  const Bad cases[] = {
      {"case,x1\npassive-on,1\n", ":1: expected the header case,x1,x2"},
      {std::string("# only a comment\n"), "bad.csv: no header"},
      {std::string(), "bad.csv: no header"},
      {kHeader, "bad.csv: no case rows"},
      {std::string(kHeader) + "passive-on,1,2\n", ":2: expected 11 cells, found 3"},
      {std::string(kHeader) + Row("semi-active", 1.0), ":2: unknown case 'semi-active'"},
      {std::string(kHeader) + Row("passive-on", 1.0) + Row("passive-on", 2.0),
       ":3: case 'passive-on' given twice"},
      {std::string(kHeader) + "passive-on,1,2,3,4,5,6,7,8,abc,10\n", ":2: xa3 'abc' is not a peak"},
      {std::string(kHeader) + "passive-on,1,2,3,4,5,6,7,8,9,-10\n", ":2: f '-10' is not a peak"},
  };
  for (const Bad& c : cases) {
    const std::string path = TempFile("bad.csv", c.text);
    Reference ref;
    std::string error;
    EXPECT_FALSE(mrd::structure::LoadReference(path, &ref, &error)) << c.message;
    EXPECT_EQ(error.rfind(path, 0), 0u) << error;
    EXPECT_NE(error.find(c.message), std::string::npos) << error;
  }
  Reference ref;
  std::string error;
  EXPECT_FALSE(mrd::structure::LoadReference("/nonexistent/ref.csv", &ref, &error));
  EXPECT_NE(error.find("/nonexistent/ref.csv: No such file or directory"), std::string::npos)
      << error;
}

TEST(StructureReferenceTest, CountsCellsOutsideTheToleranceAndChangesTheOtherWay) {
  // Measured: passive-off 2, passive-on 1, clipped-optimal 1.5 per unit (so clipped-optimal is
  // 25 % under passive-off and 50 % over passive-on in every column).
  const std::vector<Response> measured = {Uniform(Case::kPassiveOff, 2.0),
                                          Uniform(Case::kPassiveOn, 1.0),
                                          Uniform(Case::kClippedOptimal, 1.5)};
  // Reference 10 % above: every cell within 20 %, every change the same way.
  std::string path =
      TempFile("near.csv", std::string(kHeader) + Row("passive-off", 2.2) + Row("passive-on", 1.1) +
                               Row("clipped-optimal", 1.65));
  Reference ref;
  std::string error;
  ASSERT_TRUE(mrd::structure::LoadReference(path, &ref, &error)) << error;
  auto check = mrd::structure::CompareWithReference(measured, ref, 20.0);
  EXPECT_EQ(check.cells, 30);
  EXPECT_EQ(check.outside, 0);
  EXPECT_EQ(check.changes, 20);
  EXPECT_EQ(check.changes_matched, 20);
  EXPECT_EQ(mrd::structure::CompareWithReference(measured, ref, 5.0).outside, 30)
      << "10 % off is outside a 5 % tolerance";

  // Reference clipped-optimal below passive-on in every column: 10 changes the other way and
  // its 10 cells outside (1.5 measured against 0.8).
  path = TempFile("other.csv", std::string(kHeader) + Row("passive-off", 2.0) +
                                   Row("passive-on", 1.0) + Row("clipped-optimal", 0.8));
  ASSERT_TRUE(mrd::structure::LoadReference(path, &ref, &error)) << error;
  check = mrd::structure::CompareWithReference(measured, ref, 20.0);
  EXPECT_EQ(check.outside, 10);
  EXPECT_EQ(check.changes, 20);
  EXPECT_EQ(check.changes_matched, 10) << check.table;
  EXPECT_NE(check.table.find("+50 / -20*"), std::string::npos) << check.table;

  // A change within +-5 % on both sides counts as the same; +3 % against -4 % too.
  path = TempFile("flat.csv",
                  std::string(kHeader) + Row("passive-on", 1.0) + Row("clipped-optimal", 0.96));
  ASSERT_TRUE(mrd::structure::LoadReference(path, &ref, &error)) << error;
  const std::vector<Response> flat = {Uniform(Case::kPassiveOn, 1.0),
                                      Uniform(Case::kClippedOptimal, 1.03)};
  check = mrd::structure::CompareWithReference(flat, ref, 20.0);
  EXPECT_EQ(check.changes, 10);
  EXPECT_EQ(check.changes_matched, 10);
}

TEST(StructureReferenceTest, ADirectoryOrAnOversizedFileIsRefused) {
  Reference ref;
  std::string error;
  EXPECT_FALSE(mrd::structure::LoadReference("/tmp", &ref, &error));
  EXPECT_NE(error.find("directory"), std::string::npos) << error;
  const std::string big = TempFile("big.csv", std::string(kHeader) + std::string(2u << 20, '#'));
  EXPECT_FALSE(mrd::structure::LoadReference(big, &ref, &error));
  EXPECT_NE(error.find("larger than the limit"), std::string::npos) << error;
}

TEST(StructureReferenceTest, ZeroAndMissingCells) {
  Response none = Uniform(Case::kUncontrolled, 1.0);
  none.peak_force_n = 0.0;  // no damper: zero force
  const std::string path =
      TempFile("zero.csv", std::string(kHeader) + "uncontrolled,1,2,3,4,5,6,7,8,9,0\n" +
                               "passive-on,1,2,3,,,,,,,0\n");
  Reference ref;
  std::string error;
  ASSERT_TRUE(mrd::structure::LoadReference(path, &ref, &error)) << error;
  auto check = mrd::structure::CompareWithReference({none}, ref, 20.0);
  EXPECT_EQ(check.cells, 10) << "the passive-on row has no measured case: skipped";
  EXPECT_EQ(check.outside, 0) << "zero force against zero: equal";
  check = mrd::structure::CompareWithReference({Uniform(Case::kUncontrolled, 1.0)}, ref, 20.0);
  EXPECT_EQ(check.outside, 1) << "10 N against a published 0: outside";
}

}  // namespace
