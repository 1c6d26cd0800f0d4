#include "mrd/host/params_file.hpp"

#include <gtest/gtest.h>

#include "mrd/host/input_error.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

TEST(ParamsFileTest, OverridesOnTopOfPreset) {
  test::TempDir dir;
  const auto p = dir.Write("p.toml", "preset = \"spencer1997\"\neta = 200\nc0a = 1.5\n");
  const SpencerParams params = LoadSpencerParams(p);
  EXPECT_DOUBLE_EQ(params.eta, 200.0);
  EXPECT_DOUBLE_EQ(params.c0a, 1.5);
  EXPECT_DOUBLE_EQ(params.gamma, 363.0);
}

void ExpectError(const std::string& text, const std::string& fragment) {
  test::TempDir dir;
  const auto p = dir.Write("bad.toml", text);
  try {
    LoadSpencerParams(p);
    FAIL() << "no error for: " << text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(ParamsFileTest, UnknownKeyIsAnError) {
  ExpectError("c0a = 1\nbogus = 2\n", "bad.toml:2: unknown key 'bogus'");
}
TEST(ParamsFileTest, NonNumberIsAnError) {
  ExpectError("eta = \"fast\"\n", "'eta' must be a number");
}
TEST(ParamsFileTest, NegativeEtaIsAnError) { ExpectError("eta = -3\n", "invalid parameter 'eta'"); }
TEST(ParamsFileTest, SyntaxErrorNamesLine) { ExpectError("eta = 1\nc0a = = 2\n", "bad.toml:2"); }
TEST(ParamsFileTest, UnknownPresetIsAnError) { ExpectError("preset = \"x\"\n", "unknown preset"); }

}  // namespace
}  // namespace mrd::host
