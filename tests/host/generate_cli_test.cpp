// End-to-end tests of `mrd generate` through the executable.
#include <gtest/gtest.h>

#include <filesystem>

#include "mrd/host/csv.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

TEST(GenerateCliTest, WritesIdentificationSet) {
  test::TempDir dir;
  const auto out = dir.File("id.csv");
  const auto r = test::Run(test::Bin("mrd") + " generate --profile identification --out " + out);
  ASSERT_EQ(r.status, 0) << r.output;
  const DataSet ds = ReadCsv(out, std::vector<std::string>{"x", "v", "E", "f"});
  EXPECT_EQ(ds.rows(), 40001u);
  EXPECT_NEAR(ds.dt, 1e-3, 1e-9);
}

TEST(GenerateCliTest, BadParamsFileExits2AndWritesNothing) {
  test::TempDir dir;
  const auto params = dir.Write("p.toml", "eta = -1\n");
  const auto out = dir.File("v2.csv");
  const auto r =
      test::Run(test::Bin("mrd") + " generate --profile v2 --params " + params + " --out " + out);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("invalid parameter 'eta'"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(GenerateCliTest, UnknownProfileExits2) {
  test::TempDir dir;
  const auto r = test::Run(test::Bin("mrd") + " generate --profile v7 --out " + dir.File("x.csv"));
  EXPECT_EQ(r.status, 2) << r.output;
}

TEST(GenerateCliTest, HelpListsCommands) {
  const auto r = test::Run(test::Bin("mrd") + " --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("generate"), std::string::npos);
}

}  // namespace
}  // namespace mrd::host
