#include "mrd/host/csv.hpp"

#include <gtest/gtest.h>

#include <filesystem>

#include "mrd/host/input_error.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

const std::vector<std::string> kDamper{"x", "v", "E", "f"};

// Expects ReadCsv to throw InputError whose message contains every fragment.
void ExpectError(const std::string& path, const std::vector<std::string>& fragments) {
  try {
    ReadCsv(path, kDamper);
    FAIL() << "no error for " << path;
  } catch (const InputError& e) {
    for (const auto& f : fragments)
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos)
          << "'" << e.what() << "' lacks '" << f << "'";
  }
}

TEST(CsvTest, ReadsValidFileWithExtraColumn) {
  test::TempDir dir;
  const auto p =
      dir.Write("ok.csv", "t,x,v,E,f,extra\n0,1,2,3,4,5\n0.001,1,2,3,4,5\n0.002,1,2,3,4,5\n");
  const DataSet ds = ReadCsv(p, kDamper);
  EXPECT_EQ(ds.rows(), 3u);
  EXPECT_NEAR(ds.dt, 1e-3, 1e-15);
  EXPECT_EQ(ds.Column("extra")[2], 5.0);
}

TEST(CsvTest, MissingFileIsAnError) {
  ExpectError("/nonexistent/file.csv", {"/nonexistent/file.csv", "No such file or directory"});
}

TEST(CsvTest, EmptyFileIsAnError) {
  test::TempDir dir;
  ExpectError(dir.Write("e.csv", ""), {"e.csv:1", "empty"});
}

TEST(CsvTest, MissingColumnNamesTheColumn) {
  test::TempDir dir;
  ExpectError(dir.Write("m.csv", "t,x,v,f\n0,1,2,3\n0.001,1,2,3\n"), {"m.csv:1", "'E'"});
}

TEST(CsvTest, DuplicateColumnIsAnError) {
  test::TempDir dir;
  ExpectError(dir.Write("d.csv", "t,x,v,E,f,x\n"), {"d.csv:1", "duplicate"});
}

TEST(CsvTest, NonNumericValueNamesLineAndColumn) {
  test::TempDir dir;
  ExpectError(dir.Write("n.csv", "t,x,v,E,f\n0,1,2,3,4\n0.001,1,abc,3,4\n"),
              {"n.csv:3", "'v'", "abc"});
}

TEST(CsvTest, NonFiniteValueIsAnError) {
  test::TempDir dir;
  ExpectError(dir.Write("i.csv", "t,x,v,E,f\n0,1,2,3,4\n0.001,1,2,inf,4\n"),
              {"i.csv:3", "non-finite"});
  ExpectError(dir.Write("j.csv", "t,x,v,E,f\n0,nan,2,3,4\n0.001,1,2,3,4\n"),
              {"j.csv:2", "non-finite"});
  ExpectError(dir.Write("k.csv", "t,x,v,E,f\n0,1e999,2,3,4\n0.001,1,2,3,4\n"),
              {"k.csv:2", "non-finite"});
}

TEST(CsvTest, WrongFieldCountIsAnError) {
  test::TempDir dir;
  ExpectError(dir.Write("w.csv", "t,x,v,E,f\n0,1,2,3,4\n0.001,1,2,3\n"), {"w.csv:3", "expected 5"});
}

TEST(CsvTest, NonIncreasingTimeIsAnError) {
  test::TempDir dir;
  ExpectError(dir.Write("t.csv", "t,x,v,E,f\n0,1,2,3,4\n0.001,1,2,3,4\n0.001,1,2,3,4\n"),
              {"t.csv:4", "not increasing"});
}

TEST(CsvTest, NonUniformTimeIsAnError) {
  test::TempDir dir;
  ExpectError(dir.Write("u.csv", "t,x,v,E,f\n0,1,2,3,4\n0.001,1,2,3,4\n0.0025,1,2,3,4\n"),
              {"u.csv:4", "non-uniform"});
}

TEST(CsvTest, SingleRowIsAnError) {
  test::TempDir dir;
  ExpectError(dir.Write("s.csv", "t,x,v,E,f\n0,1,2,3,4\n"), {"fewer than 2"});
}

TEST(CsvTest, WriteThenReadRoundTrips) {
  test::TempDir dir;
  const auto p = dir.File("rt.csv");
  WriteCsv(p, {"t", "y"}, {{0.0, 0.5, 1.0}, {1.0 / 3.0, -2e-7, 12345.678}});
  const DataSet ds = ReadCsv(p, std::vector<std::string>{"y"});
  EXPECT_NEAR(ds.Column("y")[0], 1.0 / 3.0, 1e-10);
  EXPECT_DOUBLE_EQ(ds.Column("y")[2], 12345.678);
  EXPECT_FALSE(std::filesystem::exists(p + ".tmp"));
}

}  // namespace
}  // namespace mrd::host
