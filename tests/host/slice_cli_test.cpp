// `mrd slice` through the executable.
#include <gtest/gtest.h>

#include <filesystem>

#include "mrd/host/csv.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

std::string MakeFile(const test::TempDir& dir) {
  std::string text = "t,y\n";
  for (int k = 0; k <= 100; ++k) text += std::to_string(k * 0.01) + "," + std::to_string(k) + "\n";
  return dir.Write("in.csv", text);
}

TEST(SliceCliTest, AdjacentSlicesPartitionTheRows) {
  test::TempDir dir;
  const auto in = MakeFile(dir);
  const auto a = dir.File("a.csv"), b = dir.File("b.csv");
  ASSERT_EQ(
      test::Run(test::Bin("mrd") + " slice --in " + in + " --from 0 --to 0.7 --out " + a).status,
      0);
  ASSERT_EQ(
      test::Run(test::Bin("mrd") + " slice --in " + in + " --from 0.7 --to 2 --out " + b).status,
      0);
  const DataSet da = ReadCsv(a), db = ReadCsv(b);
  EXPECT_EQ(da.rows(), 70u);
  EXPECT_EQ(db.rows(), 31u);
  EXPECT_EQ(da.Column("y").back() + 1, db.Column("y").front());
}

TEST(SliceCliTest, EmptySliceExits2AndWritesNothing) {
  test::TempDir dir;
  const auto in = MakeFile(dir);
  const auto out = dir.File("o.csv");
  const auto r =
      test::Run(test::Bin("mrd") + " slice --in " + in + " --from 5 --to 6 --out " + out);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("fewer than 2 rows"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(SliceCliTest, ReversedBoundsExit2) {
  test::TempDir dir;
  const auto r = test::Run(test::Bin("mrd") + " slice --in " + MakeFile(dir) +
                           " --from 0.5 --to 0.2 --out " + dir.File("o.csv"));
  EXPECT_EQ(r.status, 2) << r.output;
}

}  // namespace
}  // namespace mrd::host
