// The generated header (firmware/include/mrd/firmware/builtin_table.hpp, written by
// toolchain/gen_builtin_table.sh: the paper run's selected model through mrd export) compiles,
// carries the paper model's shape (channels f, E, v; operating envelope) and encodes to an
// image that decodes to itself. That it equals the export of the checked-in model file is
// checked by builtin_table_header (gen_builtin_table.sh --check) and host_table_export_tests;
// that it equals the paper run's table by hil_builtin_is_paper_table.
#include "mrd/firmware/builtin_table.hpp"

#include <gtest/gtest.h>

#include <string>

namespace mrd::firmware {
namespace {

static_assert(kBuiltinTable.model.num_terms == 10);
static_assert(kBuiltinTable.e_max == 2.25);
static_assert(kBuiltinTable.has_envelope);

TEST(BuiltinTableTest, IsThePaperModelShape) {
  const Model& m = kBuiltinTable.model;
  ASSERT_EQ(m.num_channels, 3);
  EXPECT_EQ(std::string(m.channel_names[m.output_channel].data()), "f");
  EXPECT_EQ(std::string(m.channel_names[kBuiltinTable.input_channel].data()), "E");
  EXPECT_EQ(m.ChannelIndex("v"), 2);
  EXPECT_EQ(m.Validate(), Error::kOk);
  EXPECT_EQ(kBuiltinTable.Validate(), Error::kOk);
}

TEST(BuiltinTableTest, EncodesToAnImageThatDecodesToItself) {
  const auto a = EncodeTable(kBuiltinTable);
  ASSERT_TRUE(a.ok());
  const auto decoded = DecodeTable(a.value());
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(EncodeTable(decoded.value()).value(), a.value());
}

}  // namespace
}  // namespace mrd::firmware
