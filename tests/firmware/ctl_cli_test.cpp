// mrd-firmware ctl and SIGHUP reloads end to end: a real-time dry-run firmware with a control
// socket, driven by the ctl client (labels firmware, observe).
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "host/test_util.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }

std::string Ctl(const std::string& socket, const std::string& args) {
  return Firmware() + " ctl --socket " + socket + " " + args;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Polls until pred holds (an upper bound so a broken firmware cannot hang the test).
bool Eventually(const std::function<bool()>& pred, double limit_s = 20.0) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(limit_s);
  while (!pred()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

// A dry-run firmware in real time (30 s; stopped by the test) serving socket.
struct Running {
  Running(const std::vector<std::string>& extra, const std::string& socket)
      : child([&] {
          std::vector<std::string> argv{Firmware(), "--dry-run",    "30",
                                        "--json",   "--ctl-socket", socket};
          argv.insert(argv.end(), extra.begin(), extra.end());
          return argv;
        }()) {
    ready = WaitForPath(socket, 20.0);
  }
  ChildProcess child;
  bool ready = false;
};

TEST(CtlCliTest, ListGetSetSaveAndRefusals) {
  TempDir dir;
  const std::string cfg = dir.Write("fw.toml",
                                    "# tuned by hand\n[loop]\nperiod_us = 1000\n[control]\n"
                                    "law = \"skyhook\"  # the law\nskyhook_gain = 40.0\n");
  const std::string sock = dir.File("ctl.sock");
  Running fw({"--config", cfg}, sock);
  ASSERT_TRUE(fw.ready) << fw.child.Stderr();
  struct stat st {};
  ASSERT_EQ(lstat(sock.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0600U);

  CommandResult r = test::Run(Ctl(sock, "list"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("NAME"), std::string::npos) << r.output;
  for (const char* row : {"control.skyhook_gain", "40.0", "N s/cm", "runtime", "[0.0, 1e+06]",
                          "loop.period_us", "restart", "control.law", "\"skyhook\""}) {
    EXPECT_NE(r.output.find(row), std::string::npos) << row << "\n" << r.output;
  }
  r = test::Run(Ctl(sock, "get control.skyhook_gain"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output, "control.skyhook_gain = 40.0 N s/cm (float, [0.0, 1e+06]; runtime)\n");

  r = test::Run(Ctl(sock, "set control.skyhook_gain 55"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("control.skyhook_gain = 55.0: applied at period "), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("(parameter version 1)"), std::string::npos) << r.output;
  EXPECT_EQ(
      test::Run(Ctl(sock, "get control.skyhook_gain")).output.find("control.skyhook_gain = 55.0 "),
      0U);

  struct Refusal {
    const char* args;
    const char* says;
  };
  const Refusal refusals[] = {
      {"set control.skyhook_gain -5", "must be in [0.0, 1e+06]"},
      {"set control.skyhook_gain abc", "must be a number"},
      {"set control.nope 1", "unknown parameter 'control.nope'"},
      {"get control.nope", "unknown parameter 'control.nope'"},
      {"set loop.period_us 500", "not tunable at runtime"},
      {"set control.e_max 9", "out of range for the table"},
      {"set control.law fast", "must be one of"},
      {"frobnicate", "usage"},
      {"set control.skyhook_gain", "usage"},
  };
  for (const Refusal& f : refusals) {
    r = test::Run(Ctl(sock, f.args));
    EXPECT_EQ(r.status, 2) << f.args << ": " << r.output;
    EXPECT_NE(r.output.find(f.says), std::string::npos) << f.args << ": " << r.output;
  }
  // Nothing changed.
  EXPECT_EQ(
      test::Run(Ctl(sock, "get control.skyhook_gain")).output.find("control.skyhook_gain = 55.0 "),
      0U);
  EXPECT_NE(test::Run(Ctl(sock, "get control.e_max")).output.find("= 2.25 V"), std::string::npos);

  r = test::Run(Ctl(sock, "set envelope.margin 0.25"));
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::Run(Ctl(sock, "save"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("saved " + cfg), std::string::npos) << r.output;
  const std::string saved = Slurp(cfg);
  EXPECT_EQ(saved,
            "# tuned by hand\n[loop]\nperiod_us = 1000\n[control]\n"
            "law = \"skyhook\"  # the law\nskyhook_gain = 55.0\n\n[envelope]\nmargin = 0.25\n");
  r = test::Run(Firmware() + " --config " + cfg + " --dry-run 0.01 --lockstep --json");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("\"law\": \"skyhook\""), std::string::npos) << r.output;

  // A second firmware on the same socket is refused; the first keeps it.
  r = test::Run(Firmware() + " --dry-run 1 --ctl-socket " + sock);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("is in use by a running firmware"), std::string::npos) << r.output;
  EXPECT_EQ(test::Run(Ctl(sock, "get control.skyhook_gain")).status, 0);

  fw.child.Signal(SIGTERM);
  ASSERT_EQ(fw.child.Wait(20.0), 0) << fw.child.Stderr();
  const std::string out = fw.child.Stdout();
  EXPECT_NE(out.find("\"parameters\": {\"changes\": 2, \"reloads\": 0}"), std::string::npos) << out;
  EXPECT_NE(out.find("\"final_safe_state\": true"), std::string::npos) << out;
  EXPECT_NE(access(sock.c_str(), F_OK), 0);  // removed at exit
  r = test::Run(Ctl(sock, "list"));
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no firmware at " + sock), std::string::npos) << r.output;
}

TEST(CtlCliTest, SaveWithoutAConfigFileIsRefused) {
  TempDir dir;
  const std::string sock = dir.File("ctl.sock");
  Running fw({}, sock);
  ASSERT_TRUE(fw.ready) << fw.child.Stderr();
  const CommandResult r = test::Run(Ctl(sock, "save"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("started without --config"), std::string::npos) << r.output;
  fw.child.Signal(SIGTERM);
  EXPECT_EQ(fw.child.Wait(20.0), 0);
}

TEST(CtlCliTest, StaleSocketIsReplacedBadPathsAreRefused) {
  TempDir dir;
  // A socket file nobody serves (its firmware was killed).
  const std::string sock = dir.File("ctl.sock");
  {
    const int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::strncpy(a.sun_path, sock.c_str(), sizeof a.sun_path - 1);
    ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    close(fd);
  }
  {
    Running fw({}, sock);
    ASSERT_TRUE(fw.ready);
    ASSERT_TRUE(Eventually([&] { return test::Run(Ctl(sock, "get control.law")).status == 0; }))
        << fw.child.Stderr();
    fw.child.Signal(SIGTERM);
    EXPECT_EQ(fw.child.Wait(20.0), 0);
  }
  // Not writable: the folder is a file. Not a socket: a file at the path. Too long.
  const std::string file = dir.Write("plain.txt", "x");
  struct Bad {
    std::string path;
    const char* says;
  };
  const Bad bad[] = {{file + "/ctl.sock", "cannot create it: Not a directory"},
                     {file, "exists and is not a socket"},
                     {dir.File(std::string(120, 'a')), "must be 1 to 107 bytes"}};
  for (const Bad& b : bad) {
    const CommandResult r =
        test::Run(Firmware() + " --dry-run 1 --lockstep --ctl-socket " + b.path);
    EXPECT_EQ(r.status, 2) << b.path << ": " << r.output;
    EXPECT_NE(r.output.find(b.says), std::string::npos) << r.output;
  }
  EXPECT_EQ(Slurp(file), "x");  // never replaced
  // The config key does the same as the flag.
  const std::string cfg = dir.Write("c.toml", "[ctl]\nsocket = \"" + file + "\"\n");
  const CommandResult r = test::Run(Firmware() + " --config " + cfg + " --dry-run 1 --lockstep");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("exists and is not a socket"), std::string::npos) << r.output;
}

// Silent clients hold only their own connection: with 40 connected and saying nothing, a
// request is answered (the server serves every client side by side), and a silent one is
// dropped after its deadline.
TEST(CtlCliTest, SilentClientsDoNotHoldTheOthers) {
  TempDir dir;
  const std::string sock = dir.File("ctl.sock");
  Running fw({}, sock);
  ASSERT_TRUE(fw.ready) << fw.child.Stderr();
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, sock.c_str(), sizeof addr.sun_path - 1);
  std::vector<int> idle;
  for (int i = 0; i < 40; ++i) {
    const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0);
    ASSERT_GE(fd, 0);
    if (connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0) {
      idle.push_back(fd);
    } else {
      close(fd);  // the backlog is full: the server is not accepting
    }
  }
  EXPECT_EQ(idle.size(), 40U);
  const CommandResult r = test::Run(Ctl(sock, "get control.skyhook_gain"));
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("control.skyhook_gain = "), 0U) << r.output;
  // The first silent client is closed by the server (EOF) once its deadline passed.
  bool dropped = false;
  EXPECT_TRUE(Eventually([&] {
    char c = 0;
    dropped = !idle.empty() && recv(idle.front(), &c, 1, 0) == 0;
    return dropped;
  }));
  for (const int fd : idle) close(fd);
  fw.child.Signal(SIGTERM);
  EXPECT_EQ(fw.child.Wait(20.0), 0) << fw.child.Stderr();
}

// A reload on a bus: the demo table, allowed at start on a loopback Modbus simulation, is
// allowed on a reload too; a device profile that changed is refused (the devices run on the
// map they started with), with the reason.
TEST(CtlCliTest, ReloadTakesTheDemoTableOnALoopbackAndRefusesAChangedProfile) {
  TempDir dir;
  const std::string shipped =
      Slurp(std::string(MRD_SOURCE_DIR) + "/firmware/profiles/modbus-float32.toml");
  dir.Write("drv.toml", shipped);
  const int probe = socket(AF_INET, SOCK_STREAM, 0);  // a port nobody serves
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  ASSERT_EQ(bind(probe, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(getsockname(probe, reinterpret_cast<sockaddr*>(&a), &len), 0);
  const std::string cfg =
      dir.Write("fw.toml",
                "[loop]\npriority = 0\nlock_memory = false\n[modbus]\nmode = \"tcp\"\n"
                "host = \"127.0.0.1\"\nport = " +
                    std::to_string(ntohs(a.sin_port)) +
                    "\nprofile = \"drv.toml\"\ninputs = [\"velocity\", \"demand\"]\n"
                    "outputs = [\"command\", \"enable\"]\n");
  const std::string sock = dir.File("ctl.sock");
  ChildProcess fw({Firmware(), "--config", cfg, "--duration", "60", "--ctl-socket", sock});
  ASSERT_TRUE(WaitForPath(sock, 20.0)) << fw.Stderr();
  fw.Signal(SIGHUP);
  ASSERT_TRUE(Eventually([&] {
    return fw.Stderr().find("reloaded config") != std::string::npos ||
           fw.Stderr().find("reload refused") != std::string::npos;
  })) << fw.Stderr();
  EXPECT_EQ(fw.Stderr().find("reload refused"), std::string::npos) << fw.Stderr();
  // The profile names another register for the set-point: not applied, refused with why.
  std::string changed = shipped;
  changed.replace(changed.find("address = 0, type = \"float32\" }       # V"), 11, "address = 20");
  dir.Write("drv.toml", changed);
  fw.Signal(SIGHUP);
  ASSERT_TRUE(Eventually([&] { return fw.Stderr().find("reload refused") != std::string::npos; }))
      << fw.Stderr();
  EXPECT_NE(fw.Stderr().find("the [modbus] device profile drv.toml changed (the file, its DBC or "
                             "calibration): the devices still run on the one they started with; "
                             "restart the firmware to apply it"),
            std::string::npos)
      << fw.Stderr();
  close(probe);
  fw.Signal(SIGTERM);
  EXPECT_EQ(fw.Wait(20.0), 0) << fw.Stderr();
}

TEST(CtlCliTest, SighupWithABadTableKeepsTheOldOneAGoodOneSwitches) {
  TempDir dir;
  const std::string table = dir.File("t.bin");
  ASSERT_EQ(test::Run(Firmware() + " --write-table " + table).status, 0);
  const std::string good = Slurp(table);
  const std::string cfg =
      dir.Write("fw.toml", "[control]\nlaw = \"skyhook\"\nskyhook_gain = 40.0\n");
  const std::string sock = dir.File("ctl.sock");
  Running fw({"--config", cfg, "--table", table}, sock);
  ASSERT_TRUE(fw.ready) << fw.child.Stderr();

  // A corrupt table: refused, the firmware runs on.
  std::string bad = good;
  bad[bad.size() / 2] = static_cast<char>(bad[bad.size() / 2] ^ 0x5a);
  dir.Write("t.bin", bad);
  dir.Write("fw.toml", "[control]\nlaw = \"skyhook\"\nskyhook_gain = 70.0\n");
  fw.child.Signal(SIGHUP);
  ASSERT_TRUE(Eventually([&] {
    return fw.child.Stderr().find("reload refused") != std::string::npos;
  })) << fw.child.Stderr();
  EXPECT_NE(fw.child.Stderr().find("still running on the old config and table: table " + table +
                                   " refused: CRC mismatch"),
            std::string::npos)
      << fw.child.Stderr();
  EXPECT_TRUE(fw.child.running());
  CommandResult r = test::Run(Ctl(sock, "get control.skyhook_gain"));
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("= 40.0 "), std::string::npos) << r.output;

  // A key that needs a restart: refused, says which.
  dir.Write("t.bin", good);
  dir.Write("fw.toml", "[loop]\nperiod_us = 500\n[control]\nlaw = \"skyhook\"\n");
  fw.child.Signal(SIGHUP);
  ASSERT_TRUE(Eventually([&] {
    return fw.child.Stderr().find("keys that need a restart changed: loop.period_us") !=
           std::string::npos;
  })) << fw.child.Stderr();

  // A good table and config: switched at a period boundary, counted.
  dir.Write("fw.toml", "[control]\nlaw = \"skyhook\"\nskyhook_gain = 70.0\n");
  fw.child.Signal(SIGHUP);
  ASSERT_TRUE(Eventually([&] {
    return fw.child.Stderr().find("reloaded config") != std::string::npos;
  })) << fw.child.Stderr();
  EXPECT_NE(fw.child.Stderr().find("(parameter version 1, reload 1; model state reset)"),
            std::string::npos)
      << fw.child.Stderr();
  r = test::Run(Ctl(sock, "get control.skyhook_gain"));
  EXPECT_NE(r.output.find("= 70.0 "), std::string::npos) << r.output;

  fw.child.Signal(SIGTERM);
  ASSERT_EQ(fw.child.Wait(20.0), 0) << fw.child.Stderr();
  const std::string out = fw.child.Stdout();
  EXPECT_NE(out.find("\"parameters\": {\"changes\": 0, \"reloads\": 1}"), std::string::npos) << out;
  EXPECT_NE(out.find("\"final_safe_state\": true"), std::string::npos) << out;
}

// Command-line settings are not config changes: a firmware started with --log (and
// --ctl-socket) reloads on SIGHUP, and the log keeps being written to the same file.
TEST(CtlCliTest, SighupWithLogOnTheCommandLineReloads) {
  TempDir dir;
  const std::string cfg =
      dir.Write("fw.toml", "[control]\nlaw = \"skyhook\"\nskyhook_gain = 40.0\n");
  const std::string sock = dir.File("ctl.sock");
  const std::string log = dir.File("run.mrdlog");
  Running fw({"--config", cfg, "--log", log}, sock);
  ASSERT_TRUE(fw.ready) << fw.child.Stderr();
  dir.Write("fw.toml", "[control]\nlaw = \"skyhook\"\nskyhook_gain = 70.0\n");
  fw.child.Signal(SIGHUP);
  ASSERT_TRUE(Eventually([&] {
    const std::string e = fw.child.Stderr();
    return e.find("reloaded config") != std::string::npos ||
           e.find("reload refused") != std::string::npos;
  })) << fw.child.Stderr();
  EXPECT_EQ(fw.child.Stderr().find("reload refused"), std::string::npos) << fw.child.Stderr();
  const CommandResult r = test::Run(Ctl(sock, "get control.skyhook_gain"));
  EXPECT_NE(r.output.find("= 70.0 "), std::string::npos) << r.output;
  fw.child.Signal(SIGTERM);
  ASSERT_EQ(fw.child.Wait(20.0), 0) << fw.child.Stderr();
  const std::string out = fw.child.Stdout();
  EXPECT_NE(out.find("\"parameters\": {\"changes\": 0, \"reloads\": 1}"), std::string::npos) << out;
  EXPECT_NE(out.find("\"path\": \"" + log + "\""), std::string::npos) << out;
  struct stat st {};
  ASSERT_EQ(stat(log.c_str(), &st), 0);
  EXPECT_GT(st.st_size, 1000) << "the log was written";
}

}  // namespace
}  // namespace mrd::test
