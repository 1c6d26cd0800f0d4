// The generated header (firmware/include/mrd/firmware/builtin_table.hpp, produced by
// mrd::host::TableHeader from the demo table) compiles and encodes to the same image as the
// table it was generated from.
#include "mrd/firmware/builtin_table.hpp"

#include <gtest/gtest.h>

#include "support/demo_model.hpp"

namespace mrd::firmware {
namespace {

static_assert(kBuiltinTable.model.num_terms == 8);
static_assert(kBuiltinTable.e_max == 2.25);

TEST(BuiltinTableTest, EncodesToTheSameImageAsItsSource) {
  const auto a = EncodeTable(kBuiltinTable);
  const auto b = EncodeTable(test::DemoDamperTable());
  ASSERT_TRUE(a.ok());
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(a.value(), b.value());
  const auto decoded = DecodeTable(a.value());
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(EncodeTable(decoded.value()).value(), a.value());
}

}  // namespace
}  // namespace mrd::firmware
