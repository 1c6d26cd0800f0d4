// Conformance (labels conformance, hardening): mrd-firmware's maintenance commands and start
// on odd inputs. Paths that are not regular files (a FIFO without a writer, /dev/zero, a
// directory) are refused at once with the reason; config errors echo input as \xNN and at
// most 400 characters; every value the firmware would refuse at start (interface and host
// lengths, embedded NUL) is refused by --check-config.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "host/test_util.hpp"

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }

// Runs mrd-firmware ARGS under `timeout`: a command that blocks shows as status 124.
CommandResult Fw(const std::string& args) {
  return test::Run("timeout 20 " + Firmware() + " " + args + " </dev/null");
}

std::string Fifo(const TempDir& dir) {
  const std::string path = dir.File("fifo");
  EXPECT_EQ(mkfifo(path.c_str(), 0600), 0);
  return path;
}

TEST(FirmwareInputsConformance, DevZeroIsRefusedNotReadUntilMemoryRunsOut) {
  const CommandResult r = Fw("--check-config /dev/zero");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("error: /dev/zero: is a character device, not a regular file"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("bad_alloc"), std::string::npos) << r.output;
  EXPECT_EQ(Fw("--table /dev/zero --dry-run 0.01 --lockstep").status, 2);
}

TEST(FirmwareInputsConformance, AFifoIsRefusedWithoutBlocking) {
  TempDir dir;
  const std::string fifo = Fifo(dir);
  for (const std::string& args : {"--check-config " + fifo, "--check-table " + fifo,
                                  "--install-table " + fifo + " --to " + dir.File("dest.bin"),
                                  "--check-table " + dir.File("none.bin") + " --config " + fifo,
                                  "--table " + fifo + " --dry-run 0.01 --lockstep"}) {
    const CommandResult r = Fw(args);
    EXPECT_EQ(r.status, 2) << args << ": " << r.output;  // 124: blocked until `timeout`
    EXPECT_NE(r.output.find("is a FIFO, not a regular file"), std::string::npos)
        << args << ": " << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.File("dest.bin")));
}

TEST(FirmwareInputsConformance, ADirectoryIsNeitherAConfigNorATable) {
  TempDir dir;
  const std::string folder = dir.File("folder");
  std::filesystem::create_directory(folder);
  for (const char* command : {"--check-config", "--check-table"}) {
    const CommandResult r = Fw(std::string(command) + " " + folder);
    EXPECT_EQ(r.status, 2) << command << ": " << r.output;
    EXPECT_EQ(r.output.find(": ok"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("is a directory, not a regular file"), std::string::npos) << r.output;
  }
  const CommandResult run = Fw("--config " + folder + " --dry-run 0.01 --lockstep");
  EXPECT_EQ(run.status, 2) << run.output;
}

TEST(FirmwareInputsConformance, AConfigOverTheSizeLimitIsRefusedWithTheLimit) {
  TempDir dir;
  const std::string big = dir.File("big.toml");
  {
    std::ofstream f(big);
    f << "[loop]\n";
    for (int i = 0; i < 70000; ++i) f << "# padding padding\n";  // ~1.3 MB of comments
  }
  const CommandResult r = Fw("--check-config " + big);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("larger than the limit of 1048576 bytes"), std::string::npos) << r.output;
}

TEST(FirmwareInputsConformance, ConfigErrorsEchoControlBytesAsEscapesAndAreCapped) {
  TempDir dir;
  const std::string ctl = dir.Write("ctl.toml", "[loop]\n\"a\\u0001b\\u001b[31m\" = 1\n");
  CommandResult r = Fw("--check-config " + ctl);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("unknown key 'a\\x01b\\x1b[31m'"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find('\x01'), std::string::npos);
  EXPECT_EQ(r.output.find('\x1b'), std::string::npos);
  // A 100 kB key: the message stops at 400 characters of reason.
  const std::string long_key =
      dir.Write("long.toml", "[loop]\n" + std::string(100000, 'k') + " = 1\n");
  r = Fw("--check-config " + long_key);
  EXPECT_EQ(r.status, 2);
  EXPECT_LT(r.output.size(), 600U) << r.output.size();
  EXPECT_NE(r.output.find("more bytes)"), std::string::npos) << r.output.substr(0, 600);
  // The same through a start of the firmware.
  r = Fw("--config " + ctl + " --dry-run 0.01 --lockstep");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.output.find('\x01'), std::string::npos);
}

// Values the firmware refused only at start (exit 1 after --check-config said ok).
TEST(FirmwareInputsConformance, CheckConfigRefusesWhatTheStartWouldRefuse) {
  TempDir dir;
  const std::string can_tail = "inputs = [\"velocity\", \"demand\"]\noutputs = [\"command\"]\n";
  const struct {
    std::string name, text, reason;
  } cases[] = {
      {"ifname.toml", "[can]\ninterface = \"can0123456789abcd\"\n" + can_tail, "at most 15"},
      {"nul.toml", "[can]\ninterface = \"can\\u00000\"\n" + can_tail, "control characters"},
      {"slash.toml", "[can]\ninterface = \"can/0\"\n" + can_tail, "must not contain '/'"},
      {"socket.toml", "[can]\nlocal_bus = \"/tmp/" + std::string(120, 's') + "\"\n" + can_tail,
       "at most 107"},
      {"host.toml", "[modbus]\nhost = \"" + std::string(5000, 'h') + "\"\n" + can_tail,
       "at most 253"},
      {"host_nul.toml", "[modbus]\nhost = \"127.0.0.1\\u0000evil\"\n" + can_tail,
       "control characters"},
      {"device.toml",
       "[modbus]\ndevice = \"/dev/" + std::string(5000, 'd') + "\"\nmode = \"rtu\"\n" + can_tail,
       "at most 4095"},
  };
  for (const auto& c : cases) {
    const std::string path = dir.Write(c.name, c.text);
    const CommandResult r = Fw("--check-config " + path);
    EXPECT_EQ(r.status, 2) << c.name << ": " << r.output.substr(0, 300);
    EXPECT_NE(r.output.find(c.name + ":2: "), std::string::npos) << r.output.substr(0, 300);
    EXPECT_NE(r.output.find(c.reason), std::string::npos)
        << c.name << ": " << r.output.substr(0, 300);
  }
  // The longest accepted interface name still passes.
  const std::string ok =
      dir.Write("ok.toml", "[can]\ninterface = \"can0123456789ab\"\n" + can_tail);
  const CommandResult r = Fw("--check-config " + ok);
  EXPECT_EQ(r.status, 0) << r.output;
}

}  // namespace
}  // namespace mrd::test
