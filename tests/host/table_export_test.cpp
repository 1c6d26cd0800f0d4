#include "mrd/host/table_export.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "mrd/host/atomic_write.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/invertibility.hpp"
#include "mrd/host/model_export.hpp"
#include "mrd/host/model_file.hpp"
#include "support/demo_model.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

constexpr const char* kBuiltinHeader =
    MRD_SOURCE_DIR "/firmware/include/mrd/firmware/builtin_table.hpp";
constexpr const char* kBuiltinSymbol = "mrd::firmware::kBuiltinTable";

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The firmware's compiled-in header is the generator's output for the paper run's selected
// model (firmware/tables/paper_model.json, as `mrd export` builds it: selected iteration,
// input E in [0, 2.25] V, operating envelope, the invertibility check over the envelope grid:
// the data named in the model file are not in the repository); regenerate and compare. To
// regenerate both:
// bash toolchain/gen_builtin_table.sh (docs/plants.md).
constexpr const char* kPaperModel = MRD_SOURCE_DIR "/firmware/tables/paper_model.json";
TEST(TableExportTest, CheckedInHeaderMatchesGenerator) {
  const ModelFile mf = LoadModelFile(kPaperModel);
  CoefficientTable table = MakeTable(ToRuntimeModel(mf, mf.selected), 0.0, 2.25, "E", kPaperModel);
  ASSERT_TRUE(SetTableEnvelope(mf, &table));
  const InvertibilityReport inv = ExportInvertibility(mf, "E", table);
  EXPECT_TRUE(inv.pass()) << InvertibilitySummary(inv);
  RecordTableInvertibility(inv, &table);
  EXPECT_EQ(ReadText(kBuiltinHeader), TableHeader(table, kBuiltinSymbol));
}

TEST(TableExportTest, HeaderHasConstexprTableAndNamespaces) {
  const std::string text = TableHeader(test::DemoDamperTable(), "a::b::kTable");
  EXPECT_NE(text.find("namespace a {\nnamespace b {"), std::string::npos);
  EXPECT_NE(text.find("inline constexpr mrd::CoefficientTable kTable = [] {"), std::string::npos);
  EXPECT_NE(text.find("m.coefficients[0] = 0.85;"), std::string::npos);
  EXPECT_NE(text.find("m.channel_names[1] = {'E'};"), std::string::npos);
}

TEST(TableExportTest, RejectsSymbolThatIsNotAnIdentifier) {
  EXPECT_THROW(TableHeader(test::DemoDamperTable(), "1table"), std::invalid_argument);
  EXPECT_THROW(TableHeader(test::DemoDamperTable(), "a::"), std::invalid_argument);
  EXPECT_THROW(TableHeader(test::DemoDamperTable(), "a b"), std::invalid_argument);
}

TEST(TableExportTest, BinaryFileDecodesToTheSameImage) {
  test::TempDir dir;
  const std::string path = dir.File("table.bin");
  // As mrd export writes it (host/app/cmd_export.cpp): the image through WriteFilesAtomic.
  const TableBytes bytes = TableImage(test::DemoDamperTable());
  WriteFilesAtomic(
      {{path, std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size())}});
  const std::string data = ReadText(path);
  ASSERT_EQ(data.size(), kTableSize);
  const auto decoded =
      DecodeTable(std::span(reinterpret_cast<const std::uint8_t*>(data.data()), data.size()));
  ASSERT_TRUE(decoded.ok()) << ErrorName(decoded.error());
  EXPECT_EQ(TableImage(decoded.value()), TableImage(test::DemoDamperTable()));
}

TEST(TableExportTest, MakeTableFindsInputChannelByName) {
  const CoefficientTable t = MakeTable(test::DemoDamperModel(), 0.0, 2.25, "E");
  EXPECT_EQ(t.input_channel, 1);
  EXPECT_THROW(MakeTable(test::DemoDamperModel(), 0.0, 2.25, "I"), InputError);
  EXPECT_THROW(MakeTable(test::DemoDamperModel(), 2.25, 0.0, "E"), InputError);
}

TEST(TableExportTest, ModelOverCapacityIsRefusedWithReason) {
  Model m = test::DemoDamperModel();
  m.num_terms = kTableTerms + 1;
  try {
    MakeTable(m, 0.0, 2.25, "E", "model.json");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "model.json");
    EXPECT_NE(std::string(e.what()).find("65 terms"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("at most 64"), std::string::npos) << e.what();
  }
  m = test::DemoDamperModel();
  m.terms[2].num_factors = kTableFactors + 1;
  CoefficientTable t = test::DemoDamperTable();
  t.model = m;
  EXPECT_NE(DescribeTableProblem(t).find("5 factors in one term"), std::string::npos)
      << DescribeTableProblem(t);
  EXPECT_THROW(TableImage(t), InputError);
}

TEST(TableExportTest, FitProblemNamesEachCapacity) {
  EXPECT_EQ(TableFitProblem({3, 5, 8, 3, 2, 4}), "");
  EXPECT_NE(TableFitProblem({9, 5, 8, 3, 2, 4}).find("9 channels"), std::string::npos);
  EXPECT_NE(TableFitProblem({3, 17, 8, 3, 2, 4}).find("17 elementary regressors"),
            std::string::npos);
  EXPECT_NE(TableFitProblem({3, 5, 8, 3, 16, 4}).find("delay 16"), std::string::npos);
  EXPECT_NE(TableFitProblem({3, 5, 8, 3, 2, 17}).find("power 17"), std::string::npos);
}

}  // namespace
}  // namespace mrd::host
