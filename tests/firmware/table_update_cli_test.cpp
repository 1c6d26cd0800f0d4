// Issue 11 (label cross): table installation on a board through mrd-firmware — atomic install
// with the previous table kept, refusal of bad tables with nothing changed, rollback when the
// installed table is refused at start, --check-config / --check-table for ExecStartPre.
// Runs under qemu-user in the cross builds (Bin() carries the emulator).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "host/test_util.hpp"
#include "mrd/common/table.hpp"

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }

bool Exists(const std::string& path) { return std::filesystem::exists(path); }

// Table A: the compiled-in one (E in [0, 2.25] V). Table B: the same model with E_max 2.0 V,
// so a config asking for E_max 2.25 V accepts A and refuses B.
struct Tables {
  explicit Tables(const TempDir& dir) : a(dir.File("a.bin")), b(dir.File("b.bin")) {
    EXPECT_EQ(test::Run(Firmware() + " --write-table " + a).status, 0);
    const std::string image = FileBytes(a);
    auto decoded = DecodeTable(std::span<const std::uint8_t>(
        reinterpret_cast<const std::uint8_t*>(image.data()), image.size()));
    EXPECT_TRUE(decoded.ok());
    CoefficientTable t = decoded.value();
    t.e_max = 2.0;
    const auto encoded = EncodeTable(t);
    EXPECT_TRUE(encoded.ok());
    std::ofstream(b, std::ios::binary)
        .write(reinterpret_cast<const char*>(encoded.value().data()),
               static_cast<std::streamsize>(encoded.value().size()));
  }
  std::string a;
  std::string b;
};

TEST(TableUpdateTest, InstallReplacesAtomicallyAndKeepsThePreviousTable) {
  TempDir dir;
  const Tables t(dir);
  const std::string dest = dir.File("table.bin");
  CommandResult r = test::Run(Firmware() + " --install-table " + t.a + " --to " + dest);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(FileBytes(dest), FileBytes(t.a));
  EXPECT_FALSE(Exists(dest + ".prev"));
  r = test::Run(Firmware() + " --install-table " + t.b + " --to " + dest);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(FileBytes(dest), FileBytes(t.b));
  EXPECT_EQ(FileBytes(dest + ".prev"), FileBytes(t.a));
  EXPECT_FALSE(Exists(dest + ".new"));
  EXPECT_EQ(test::Run(Firmware() + " --check-table " + dest).status, 0);
}

TEST(TableUpdateTest, RefusedTableInstallsNothing) {
  TempDir dir;
  const Tables t(dir);
  const std::string dest = dir.File("table.bin");
  ASSERT_EQ(test::Run(Firmware() + " --install-table " + t.a + " --to " + dest).status, 0);
  // Corrupt image (CRC): exit 2 with the reason, DEST and the folder unchanged.
  const std::string bad = dir.File("bad.bin");
  std::string image = FileBytes(t.b);
  image[100] = static_cast<char>(image[100] ^ 0x5A);
  std::ofstream(bad, std::ios::binary) << image;
  CommandResult r = test::Run(Firmware() + " --install-table " + bad + " --to " + dest);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("error: table " + bad + " refused"), std::string::npos) << r.output;
  // Incompatible with the config (E_max 2.25 V outside B's range).
  const std::string cfg = dir.Write("fw.toml", "[control]\ne_max = 2.25\n");
  r = test::Run(Firmware() + " --install-table " + t.b + " --to " + dest + " --config " + cfg);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("refused by this firmware and config"), std::string::npos) << r.output;
  // Missing source, missing --to.
  EXPECT_EQ(
      test::Run(Firmware() + " --install-table " + dir.File("none.bin") + " --to " + dest).status,
      2);
  EXPECT_EQ(test::Run(Firmware() + " --install-table " + t.b).status, 2);
  EXPECT_EQ(FileBytes(dest), FileBytes(t.a));
  EXPECT_FALSE(Exists(dest + ".prev"));
  EXPECT_FALSE(Exists(dest + ".new"));
}

TEST(TableUpdateTest, TableRefusedAtStartRollsBackToThePreviousOne) {
  TempDir dir;
  const Tables t(dir);
  const std::string dest = dir.File("table.bin");
  const std::string cfg = dir.Write("fw.toml", "[control]\ne_max = 2.25\n");
  ASSERT_EQ(test::Run(Firmware() + " --install-table " + t.a + " --to " + dest + " --config " + cfg)
                .status,
            0);
  // Installed without the board's config: accepted then, refused at start with it.
  ASSERT_EQ(test::Run(Firmware() + " --install-table " + t.b + " --to " + dest).status, 0);
  CommandResult r = test::Run(Firmware() + " --check-table " + dest + " --config " + cfg);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_EQ(FileBytes(dest), FileBytes(t.b));  // a check alone changes nothing
  r = test::Run(Firmware() + " --check-table " + dest + " --config " + cfg + " --rollback");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("rolled back"), std::string::npos) << r.output;
  EXPECT_EQ(FileBytes(dest), FileBytes(t.a));
  EXPECT_EQ(FileBytes(dest + ".refused"), FileBytes(t.b));
  EXPECT_FALSE(Exists(dest + ".prev"));
  r = test::Run(Firmware() + " --table " + dest + " --config " + cfg + " --dry-run 0.2 --lockstep");
  EXPECT_EQ(r.status, 0) << r.output;
  // Corrupted on disk with no previous table left: refused, nothing to roll back to.
  std::string image = FileBytes(dest);
  image[64] = static_cast<char>(image[64] ^ 0x5A);
  std::ofstream(dest, std::ios::binary) << image;
  r = test::Run(Firmware() + " --check-table " + dest + " --rollback");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("no previous table"), std::string::npos) << r.output;
}

TEST(TableUpdateTest, CheckConfigAndArguments) {
  TempDir dir;
  const std::string good =
      dir.Write("good.toml",
                "[control]\ne_max = 2.0\n[can]\ninterface = \"can0\"\n"
                "inputs = [\"velocity\", \"demand\"]\noutputs = [\"command\"]\n");
  const std::string bad = dir.Write("bad.toml", "[control]\nfoo = 1\n");
  EXPECT_EQ(test::Run(Firmware() + " --check-config " + good).status, 0);
  const CommandResult r = test::Run(Firmware() + " --check-config " + bad);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("bad.toml:2: unknown key 'foo'"), std::string::npos) << r.output;
  EXPECT_EQ(test::Run(Firmware() + " --check-config " + dir.File("none.toml")).status, 2);
  EXPECT_EQ(test::Run(Firmware() + " --check-config").status, 2);
  EXPECT_EQ(test::Run(Firmware() + " --check-table " + good + " --bogus").status, 2);
}

}  // namespace
}  // namespace mrd::test
