// Issue 14 (hardening): bad input and faults through the `mrd` executable. Each test names the
// behaviour; each failed on the main of the campaign (docs/design.md §8).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrd/host/csv.hpp"
#include "mrd/host/plot.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

namespace fs = std::filesystem;
using test::Bin;
using test::CommandResult;
using test::TempDir;

std::string Mrd() { return Bin("mrd"); }

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Quotes a shell word.
std::string Q(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// y(k) = 0.5 y(k-1) + u(k) + 0.3 u(k)^2 on a deterministic pseudo-random u in [-1, 1].
std::string WriteToy(const TempDir& dir, const std::string& name, std::size_t n = 600) {
  std::vector<double> t(n), u(n), y(n, 0.0);
  std::uint64_t s = 12345;
  for (std::size_t k = 0; k < n; ++k) {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    t[k] = 0.01 * static_cast<double>(k);
    u[k] = 2.0 * static_cast<double>(s >> 11) / 9007199254740992.0 - 1.0;
    y[k] = (k > 0 ? 0.5 * y[k - 1] : 0.0) + u[k] + 0.3 * u[k] * u[k];
  }
  WriteCsv(dir.File(name), {"t", "u", "y"}, {t, u, y});
  return dir.File(name);
}

std::string ToySpec(const std::string& u_transform = "transform = \"identity\"",
                    const std::string& limits = "max_factors = 2\nmax_degree = 2") {
  return "output = \"y\"\n[[regressor]]\nname = \"y\"\nsignal = \"y\"\ntransform = "
         "\"identity\"\npowers = [1, 2]\ndelays = [1]\n[[regressor]]\nname = \"u1\"\nsignal = "
         "\"u\"\n" +
         u_transform + "\npowers = [1, 2]\ndelays = [0, 1]\n[limits]\n" + limits +
         "\n[cost]\nweighting = \"mse\"\n[algorithm]\nmax_iterations = 4\n";
}

// A fitted toy model in dir: model.json (and id.csv, toy.toml).
struct Toy {
  std::string data, spec, model;
};
Toy MakeToyModel(const TempDir& dir) {
  Toy t{WriteToy(dir, "id.csv"), dir.Write("toy.toml", ToySpec()), dir.File("model.json")};
  const CommandResult r = test::Run(Mrd() + " identify --data " + t.data + " --spec " + t.spec +
                                    " --out " + t.model + " --threads 1");
  EXPECT_EQ(r.status, 0) << r.output;
  return t;
}

// Defect 1.
TEST(HardeningTest, RepeatedFactorPowersAreCheckedAgainstTheLimit) {
  TempDir dir;
  const std::string data = WriteToy(dir, "id.csv");
  const std::string spec = dir.Write("toy.toml", ToySpec());
  for (const char* term : {"u1(k)^16*u1(k)", "u1(k)^16*u1(k)^16"}) {
    const CommandResult r = test::Run(Mrd() + " identify --data " + data + " --spec " + spec +
                                      " --out " + dir.File("m.json") + " --initial " + Q(term));
    EXPECT_EQ(r.status, 2) << term << ": " << r.output;
    EXPECT_NE(r.output.find("out of range"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir.File("m.json")));
  }
  const std::string in_spec =
      dir.Write("init.toml", ToySpec() + "initial = [\"u1(k)^16*u1(k)^16\"]\n");
  const CommandResult r = test::Run(Mrd() + " identify --data " + data + " --spec " + in_spec +
                                    " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("power 32 out of range"), std::string::npos) << r.output;
}

// Defect 2: temporaries never follow a symlink; special files are not replaced.
TEST(HardeningTest, OutputNeverWritesThroughSymlinksOrReplacesSpecialFiles) {
  TempDir dir;
  const std::string data = WriteToy(dir, "in.csv");
  const std::string victim = dir.Write("victim.txt", "precious\n");
  ASSERT_EQ(symlink(victim.c_str(), dir.File("x.csv.tmp").c_str()), 0);
  CommandResult r =
      test::Run(Mrd() + " slice --in " + data + " --from 0 --to 1 --out " + dir.File("x.csv"));
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(Slurp(victim), "precious\n");
  EXPECT_NE(Slurp(dir.File("x.csv")).find("t,u,y"), std::string::npos);

  // --out itself a symlink to the victim: refused, victim intact.
  ASSERT_EQ(symlink(victim.c_str(), dir.File("link.csv").c_str()), 0);
  r = test::Run(Mrd() + " slice --in " + data + " --from 0 --to 1 --out " + dir.File("link.csv"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_EQ(Slurp(victim), "precious\n");

  // A FIFO (as a device node would be) is not replaced by a regular file.
  ASSERT_EQ(mkfifo(dir.File("fifo").c_str(), 0600), 0);
  r = test::Run(Mrd() + " slice --in " + data + " --from 0 --to 1 --out " + dir.File("fifo"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("not a regular file"), std::string::npos) << r.output;
  struct stat st {};
  ASSERT_EQ(lstat(dir.File("fifo").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  // No temporary left behind by any of these runs.
  for (const auto& e : fs::directory_iterator(dir.File(""))) {
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
  }
}

// Defect 2: concurrent writers of one output both succeed and leave one writer's whole file.
TEST(HardeningTest, ConcurrentWritersOfOneOutputLeaveOneWholeFile) {
  TempDir dir;
  const std::string data = WriteToy(dir, "in.csv", 40000);
  auto slice = [&](const char* to, const std::string& out) {
    return Mrd() + " slice --in " + data + " --from 0 --to " + to + " --out " + out;
  };
  ASSERT_EQ(test::Run(slice("300", dir.File("a.csv"))).status, 0);
  ASSERT_EQ(test::Run(slice("200", dir.File("b.csv"))).status, 0);
  const std::string a = Slurp(dir.File("a.csv")), b = Slurp(dir.File("b.csv"));
  const std::string out = dir.File("out.csv");
  // A temporary of another writer still at work (the fixed name OUT.tmp of old) is not touched.
  const std::string other = dir.Write("out.csv.tmp", "another writer\n");
  for (int round = 0; round < 5; ++round) {
    const CommandResult r =
        test::Run(std::string("(") + slice("300", out) + " || echo FAILED) & (" +
                  slice("200", out) + " || echo FAILED) & wait");
    EXPECT_EQ(r.output.find("FAILED"), std::string::npos) << r.output;
    const std::string got = Slurp(out);
    EXPECT_TRUE(got == a || got == b) << "round " << round << ": " << got.size() << " bytes";
  }
  EXPECT_EQ(Slurp(other), "another writer\n");
}

// Defect 4: export writes both outputs or neither.
TEST(HardeningTest, ExportWritesBothOutputsOrNeither) {
  TempDir dir;
  const Toy toy = MakeToyModel(dir);
  const CommandResult r =
      test::Run(Mrd() + " export --model " + toy.model + " --input u --e-min 0 --e-max 1 --table " +
                dir.File("t.bin") + " --header " + dir.File("nodir/t.hpp"));
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_FALSE(fs::exists(dir.File("t.bin")));
  const CommandResult ok =
      test::Run(Mrd() + " export --model " + toy.model + " --input u --e-min 0 --e-max 1 --table " +
                dir.File("t.bin") + " --header " + dir.File("t.hpp"));
  EXPECT_EQ(ok.status, 0) << ok.output;
  EXPECT_TRUE(fs::exists(dir.File("t.bin")));
  EXPECT_TRUE(fs::exists(dir.File("t.hpp")));
}

// Consistency: a model the firmware cannot invert is refused by export too.
TEST(HardeningTest, ExportRefusesTablesTheFirmwareCannotInvert) {
  TempDir dir;
  const std::string data = WriteToy(dir, "id.csv");
  const std::string spec =
      dir.Write("abs.toml", ToySpec("transform = \"abs_pow\"\nexponent = 0.5"));
  const std::string model = dir.File("m.json");
  ASSERT_EQ(test::Run(Mrd() + " identify --data " + data + " --spec " + spec + " --out " + model +
                      " --initial 'u1(k)' --max-iterations 0")
                .status,
            0);
  const CommandResult r = test::Run(Mrd() + " export --model " + model +
                                    " --input u --e-min 0 --e-max 1 --table " + dir.File("t.bin"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("not invertible"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir.File("t.bin")));
}

// Defect 5: integer fields of the model file are integers in range, never converted.
TEST(HardeningTest, ModelFileNumbersAreNeverSilentlyChanged) {
  TempDir dir;
  const Toy toy = MakeToyModel(dir);
  const nlohmann::json good = nlohmann::json::parse(Slurp(toy.model));
  ASSERT_GE(good["iterations"].size(), 2u);
  struct Case {
    const char* what;
    std::function<void(nlohmann::json&)> edit;
    const char* field;
  };
  const std::vector<Case> cases = {
      {"huge selected", [](nlohmann::json& j) { j["selected"] = 1099511627776ULL; }, "selected"},
      {"fractional selected", [](nlohmann::json& j) { j["selected"] = 1.5; }, "selected"},
      {"huge delay",
       [](nlohmann::json& j) {
         j["iterations"][1]["terms"][0]["factors"][0]["delay"] = 1099511627776ULL;
       },
       "delay"},
      {"delay not offered",
       [](nlohmann::json& j) { j["iterations"][1]["terms"][0]["factors"][0]["delay"] = 7; },
       "delay"},
      {"duplicate iteration", [](nlohmann::json& j) { j["iterations"][1]["iteration"] = 0; },
       "iteration 0"},
  };
  for (const Case& c : cases) {
    nlohmann::json j = good;
    c.edit(j);
    const std::string path = dir.Write("bad.json", j.dump());
    const CommandResult r = test::Run(Mrd() + " simulate --model " + path + " --data " + toy.data);
    EXPECT_EQ(r.status, 2) << c.what << ": " << r.output;
    EXPECT_NE(r.output.find(c.field), std::string::npos) << c.what << ": " << r.output;
    EXPECT_NE(r.output.find("bad.json"), std::string::npos) << c.what << ": " << r.output;
  }
}

// Defect 6: non-finite data is never written.
TEST(HardeningTest, NonFiniteDataIsNeverWritten) {
  TempDir dir;
  const std::string in = dir.Write("raw.csv",
                                   "time,d,vel,volt,force\n0,1,1,1,1e10\n"
                                   "0.001,1,1,1,2e10\n0.002,1,1,1,3e10\n");
  CommandResult r = test::Run(Mrd() + " import --in " + in +
                              " --map t=time,x=d,v=vel,E=volt,f=force --scale f=1e306 --rate 1000"
                              " --out " +
                              dir.File("out.csv"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_FALSE(fs::exists(dir.File("out.csv")));
  const std::string params = dir.Write("p.toml", "alpha_a = 1e308\n");
  r = test::Run(Mrd() + " generate --profile v1 --params " + params + " --out " +
                dir.File("gen.csv"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("non-finite"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir.File("gen.csv")));
}

// Defect 8: bad input gets exit 2 and a message that names the cause.
TEST(HardeningTest, BadInputGetsExitTwoAndAReadableReason) {
  TempDir dir;
  const Toy toy = MakeToyModel(dir);
  std::string text = Slurp(toy.model);
  const std::string model_1e400 =
      dir.Write("big.json",
                std::string(text).replace(text.find("\"coefficient\": ") + 15, 1, "1e400,\"x\":"));
  CommandResult r = test::Run(Mrd() + " simulate --model " + model_1e400 + " --data " + toy.data);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("big.json"), std::string::npos) << r.output;

  nlohmann::json j = nlohmann::json::parse(text);
  j["spec"]["algorithm"]["target_j"] = nullptr;
  r = test::Run(Mrd() + " simulate --model " + dir.Write("null.json", j.dump()) + " --data " +
                toy.data);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("target_j"), std::string::npos) << r.output;

  r = test::Run(Mrd() + " export --model " + toy.model +
                " --input u --e-min 0 --e-max 1 "
                "--header " +
                dir.File("h.hpp") + " --symbol 'a b'");
  EXPECT_EQ(r.status, 2) << r.output;
  r = test::Run(Mrd() + " slice --in " + toy.data + " --from 0 --to 1 --out ''");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("empty"), std::string::npos) << r.output;

  // Tiny time step: the filter length is reported, not an overflowed integer.
  const std::string tiny = dir.Write("tiny.csv",
                                     "t,x,v,E,f\n0,0,0,0,0\n1e-300,0,0,0,0\n"
                                     "2e-300,0,0,0,0\n3e-300,0,0,0,0\n");
  r = test::Run(Mrd() + " import --in " + tiny + " --map t=t,x=x,v=v,E=E,f=f --rate 1000 --out " +
                dir.File("o.csv"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_EQ(r.output.find("-9223372036854775"), std::string::npos) << r.output;

  // A 10 MB field and raw binary bytes are not echoed whole.
  const std::string huge =
      dir.Write("huge.csv", "t,u,y\n0,0," + std::string(10'000'000, '7') + "x\n1,0,0\n");
  r = test::Run(Mrd() + " slice --in " + huge + " --from 0 --to 1 --out " + dir.File("o.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_LT(r.output.size(), 2000u);
  const std::string bin =
      dir.Write("bin.csv", std::string("t,u,y\n0,\x01\x02\xff\x1b[31m,0\n1,0,0\n"));
  r = test::Run(Mrd() + " slice --in " + bin + " --from 0 --to 1 --out " + dir.File("o.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find('\xff'), std::string::npos) << r.output;

  // CR-only line ends are named as such.
  const std::string cr = dir.Write("cr.csv", "t,u,y\r0,0,0\r1,0,0\r");
  r = test::Run(Mrd() + " slice --in " + cr + " --from 0 --to 1 --out " + dir.File("o.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("carriage return"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir.File("o.csv")));
}

// Defect 9: too little or constant data, and a NaN target, are refused.
TEST(HardeningTest, DegenerateIdentificationsAreRefused) {
  TempDir dir;
  const std::string spec = dir.Write("toy.toml", ToySpec());
  const std::string three = WriteToy(dir, "three.csv", 3);
  CommandResult r = test::Run(Mrd() + " identify --data " + three + " --spec " + spec + " --out " +
                              dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("per parameter"), std::string::npos) << r.output;
  std::string flat = "t,u,y\n";
  for (int k = 0; k < 100; ++k) flat += std::to_string(0.01 * k) + ",0,0\n";
  r = test::Run(Mrd() + " identify --data " + dir.Write("flat.csv", flat) + " --spec " + spec +
                " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("constant"), std::string::npos) << r.output;
  r = test::Run(Mrd() + " identify --data " + WriteToy(dir, "id.csv") + " --spec " + spec +
                " --out " + dir.File("m.json") + " --target-j nan");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_FALSE(fs::exists(dir.File("m.json")));
  // 30 samples: at most 3 parameters.
  r = test::Run(Mrd() + " identify --data " + WriteToy(dir, "short.csv", 31) + " --spec " + spec +
                " --out " + dir.File("m.json"));
  ASSERT_EQ(r.status, 0) << r.output;
  const auto model = nlohmann::json::parse(Slurp(dir.File("m.json")));  // outlives the loop
  for (const auto& it : model["iterations"]) {
    EXPECT_LE(it["terms"].size(), 3u);
  }
}

// Defect 10: the candidate set is counted before anything is built.
TEST(HardeningTest, OversizedCandidateSetsAreRefusedWithTheirCount) {
  TempDir dir;
  std::string spec = "output = \"y\"\n";
  for (int r = 0; r < 16; ++r) {
    spec +=
        "[[regressor]]\nname = \"r" + std::to_string(r) + "\"\nsignal = \"" + (r == 0 ? "y" : "u") +
        "\"\ntransform = \"identity\"\npowers = [1, 2, 3, 4, 5, 6, 7, "
        "8, 9, 10, 11, 12, 13, 14, 15, 16]\ndelays = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13,"
        " 14, 15]\n";
  }
  spec += "[limits]\nmax_factors = 16\n";
  const CommandResult r =
      test::Run("timeout 60 " + Mrd() + " identify --data " + WriteToy(dir, "id.csv") + " --spec " +
                dir.Write("big.toml", spec) + " --out " + dir.File("m.json"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("candidate set too large"), std::string::npos) << r.output;
  const CommandResult small = test::Run(Mrd() + " identify --data " + WriteToy(dir, "id2.csv") +
                                        " --spec " + dir.Write("toy.toml", ToySpec()) +
                                        " --max-candidates 3 --out " + dir.File("m.json"));
  EXPECT_EQ(small.status, 2) << small.output;
}

// Defect 11: a failed write of the result is an error.
TEST(HardeningTest, SimulateJsonToAFullDeviceFails) {
  if (access("/dev/full", W_OK) != 0) GTEST_SKIP() << "no /dev/full";
  TempDir dir;
  const Toy toy = MakeToyModel(dir);
  const CommandResult r = test::Run(std::string("(") + Mrd() + " simulate --json --model " +
                                    toy.model + " --data " + toy.data + " > /dev/full)");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("error"), std::string::npos) << r.output;
}

// Defect 12: a report into a writable DIR whose parent is read-only stages inside DIR.
TEST(HardeningTest, ReportWritesIntoAWritableDirectoryUnderAReadOnlyParent) {
  if (!GnuplotAvailable()) GTEST_SKIP() << "gnuplot not installed";
  TempDir dir;
  const Toy toy = MakeToyModel(dir);
  fs::permissions(dir.File(""), fs::perms::all, fs::perm_options::add);
  fs::create_directory(dir.File("p"));
  fs::create_directory(dir.File("p/rep"));
  fs::permissions(dir.File(toy.model), fs::perms::all, fs::perm_options::add);
  fs::permissions(dir.File(toy.data), fs::perms::all, fs::perm_options::add);
  // Root writes anywhere: run the report as 'nobody', owner of p/rep only.
  std::string prefix;
  if (geteuid() == 0) {
    ASSERT_EQ(chown(dir.File("p/rep").c_str(), 65534, 65534), 0);
    prefix = "setpriv --reuid=65534 --regid=65534 --clear-groups ";
  }
  fs::permissions(dir.File("p"),
                  fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write,
                  fs::perm_options::remove);
  const CommandResult r = test::Run(prefix + Mrd() + " report --model " + toy.model + " --data " +
                                    toy.data + " --out " + dir.File("p/rep"));
  fs::permissions(dir.File("p"), fs::perms::owner_write, fs::perm_options::add);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir.File("p/rep/summary.txt"))) << r.output;
  for (const auto& e : fs::directory_iterator(dir.File("p/rep"))) {
    EXPECT_NE(e.path().filename().string().front(), '.') << "staging left: " << e.path();
  }
}

// Defect 12: when no staging place is writable the system error text is printed.
TEST(HardeningTest, ReportPrintsTheSystemErrorWhenItCannotStage) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to run as another user";
  TempDir dir;
  const Toy toy = MakeToyModel(dir);
  fs::permissions(dir.File(""), fs::perms::all, fs::perm_options::add);
  fs::permissions(dir.File(toy.model), fs::perms::all, fs::perm_options::add);
  fs::permissions(dir.File(toy.data), fs::perms::all, fs::perm_options::add);
  fs::create_directory(dir.File("p"));
  fs::permissions(dir.File("p"),
                  fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write,
                  fs::perm_options::remove);
  const CommandResult r =
      test::Run("setpriv --reuid=65534 --regid=65534 --clear-groups " + Mrd() + " report --model " +
                toy.model + " --data " + toy.data + " --out " + dir.File("p/rep"));
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("Permission denied"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace mrd::host
