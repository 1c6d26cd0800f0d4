// `mrd export` through the executable: identify -> export -> decode / mrd-firmware.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "mrd/common/table.hpp"
#include "test_util.hpp"

namespace mrd {
namespace {

// Identification data and a 3-iteration model of the paper spec in dir.
std::string MakeModel(const test::TempDir& dir) {
  const auto data = dir.File("id.csv");
  const auto model = dir.File("m.json");
  EXPECT_EQ(test::Run(test::Bin("mrd") + " generate --profile identification --out " + data).status,
            0);
  const auto r =
      test::Run(test::Bin("mrd") + " identify --data " + data + " --spec " +
                MRD_SOURCE_DIR "/host/specs/paper.toml --max-iterations 3 --out " + model);
  EXPECT_EQ(r.status, 0) << r.output;
  return model;
}

std::vector<std::uint8_t> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(ExportCliTest, WritesTableAndHeaderTheFirmwareAccepts) {
  test::TempDir dir;
  const auto model = MakeModel(dir);
  const auto bin = dir.File("t.bin"), hpp = dir.File("t.hpp");
  const auto r =
      test::Run(test::Bin("mrd") + " export --model " + model + " --iteration 3 --table " + bin +
                " --header " + hpp + " --symbol demo::kTable");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto bytes = ReadBytes(bin);
  const Result<CoefficientTable> t = DecodeTable(bytes);
  ASSERT_TRUE(t.ok()) << ErrorName(t.error());
  EXPECT_EQ(t.value().model.num_terms, 3);
  std::ifstream h(hpp);
  const std::string text{std::istreambuf_iterator<char>(h), {}};
  EXPECT_NE(text.find("namespace demo"), std::string::npos);
  EXPECT_NE(text.find("kTable"), std::string::npos);
  const auto fw =
      test::Run(test::Bin("mrd-firmware") + " --table " + bin + " --dry-run 0.5 --lockstep --json");
  EXPECT_EQ(fw.status, 0) << fw.output;
  EXPECT_NE(fw.output.find("\"ticks\": 500"), std::string::npos) << fw.output;
}

TEST(ExportCliTest, UnknownInputChannelExits2AndWritesNothing) {
  test::TempDir dir;
  const auto model = MakeModel(dir);
  const auto bin = dir.File("t.bin"), hpp = dir.File("t.hpp");
  const auto r = test::Run(test::Bin("mrd") + " export --model " + model + " --input Q --table " +
                           bin + " --header " + hpp);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_FALSE(std::filesystem::exists(bin));
  EXPECT_FALSE(std::filesystem::exists(hpp));
}

TEST(ExportCliTest, MissingIterationExits2) {
  test::TempDir dir;
  const auto model = MakeModel(dir);
  const auto r = test::Run(test::Bin("mrd") + " export --model " + model +
                           " --iteration 99 --table " + dir.File("t.bin"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("t.bin")));
}

TEST(ExportCliTest, NoOutputGivenExits2) {
  test::TempDir dir;
  const auto model = MakeModel(dir);
  const auto r = test::Run(test::Bin("mrd") + " export --model " + model);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--table"), std::string::npos);
}

TEST(ExportCliTest, EmptyVoltageRangeExits2) {
  test::TempDir dir;
  const auto model = MakeModel(dir);
  const auto r = test::Run(test::Bin("mrd") + " export --model " + model +
                           " --e-min 2 --e-max 1 --table " + dir.File("t.bin"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.File("t.bin")));
}

}  // namespace
}  // namespace mrd
