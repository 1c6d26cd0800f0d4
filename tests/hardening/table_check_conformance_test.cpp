// Conformance (labels conformance, hardening): tables that pass the CRC but break the rules
// of docs/table_format.md (a normalisation that overflows every period, non-zero reserved or
// unused bytes, two channels of one name, an input range outside [0, 24] V) are refused by
// --check-table, --install-table and --table with the reason, and nothing is installed.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "host/test_util.hpp"
#include "mrd/common/crc32.hpp"
#include "mrd/common/table.hpp"

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }

CommandResult Fw(const std::string& args) {
  return test::Run("timeout 20 " + Firmware() + " " + args + " </dev/null");
}

// The compiled-in table's image with patches, resealed (CRC).
std::string PatchedTable(const TempDir& dir, const std::string& name,
                         const std::vector<std::pair<std::size_t, double>>& f64,
                         const std::vector<std::pair<std::size_t, std::uint8_t>>& u8) {
  const std::string base = dir.File("base.bin");
  EXPECT_EQ(test::Run(Firmware() + " --write-table " + base).status, 0);
  std::string image = FileBytes(base);
  EXPECT_EQ(image.size(), kTableSize);
  for (const auto& [at, v] : f64) {
    const auto u = std::bit_cast<std::uint64_t>(v);
    for (std::size_t i = 0; i < 8; ++i) image[at + i] = static_cast<char>(u >> (8 * i));
  }
  for (const auto& [at, v] : u8) image[at] = static_cast<char>(v);
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(
      reinterpret_cast<const std::uint8_t*>(image.data()), kTableCrcOffset));
  for (std::size_t i = 0; i < 4; ++i)
    image[kTableCrcOffset + i] = static_cast<char>(crc >> (8 * i));
  const std::string path = dir.File(name);
  std::ofstream(path, std::ios::binary) << image;
  return path;
}

TEST(TableCheckConformance, AbsurdTablesAreRefusedWithTheReason) {
  TempDir dir;
  const std::size_t ch0 = kTableChannelsOffset, ch1 = ch0 + kTableChannelRecord;
  // Offsets and names as laid out in the compiled-in table (the paper run's model: channels f,
  // E, v; 10 terms).
  const struct {
    std::string name;
    std::vector<std::pair<std::size_t, double>> f64;
    std::vector<std::pair<std::size_t, std::uint8_t>> u8;
    std::string reason;
  } cases[] = {
      {"offset.bin", {{ch0 + 16, 1e308}}, {}, "channel 'f' normalisation offset 1e+308"},
      {"scale.bin", {{ch1 + 24, 5e-324}}, {}, "channel 'E' normalisation"},
      {"reserved.bin", {}, {{17, 1}}, "byte 17 (header, reserved) is 0x01, must be 0"},
      {"nan.bin",
       {{kTableCoefficientsOffset + 8 * 20, std::nan("")}},
       {},
       "(coefficient 20 (unused: the table has 10 terms))"},
      {"names.bin", {}, {{ch1, 'v'}}, "channels 1 and 2 are both named 'v'"},
      {"emin.bin", {{kTableRangeOffset, -5.0}}, {}, "input range [-5, 2.25] V"},
      {"emax.bin", {{kTableRangeOffset + 8, 1000.0}}, {}, "input range [0, 1000] V"},
  };
  const std::string dest = dir.File("table.bin");
  ASSERT_EQ(test::Run(Firmware() + " --write-table " + dest).status, 0);
  const std::string before = FileBytes(dest);
  for (const auto& c : cases) {
    const std::string path = PatchedTable(dir, c.name, c.f64, c.u8);
    CommandResult r = Fw("--check-table " + path);
    EXPECT_EQ(r.status, 2) << c.name << ": " << r.output;
    EXPECT_NE(r.output.find("error: table " + path + " refused: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(c.reason), std::string::npos) << c.name << ": " << r.output;
    r = Fw("--install-table " + path + " --to " + dest);
    EXPECT_EQ(r.status, 2) << c.name << ": " << r.output;
    EXPECT_NE(r.output.find("(nothing installed)"), std::string::npos) << r.output;
    r = Fw("--table " + path + " --dry-run 0.01 --lockstep");
    EXPECT_EQ(r.status, 2) << c.name << ": " << r.output;
  }
  EXPECT_EQ(FileBytes(dest), before);
  EXPECT_FALSE(std::filesystem::exists(dest + ".prev"));
}

}  // namespace
}  // namespace mrd::test
