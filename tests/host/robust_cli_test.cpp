// `mrd` through the executable on bad input: directories as input files, iterations that do not
// exist or do not read the input, rates and data that leave nothing to write or fit, non-finite
// options, a diverging simulation, unwritable outputs, C++ keywords as symbols, repeated log
// fields, a model file with a key given twice. Each refusal: exit 2, one line naming the file,
// nothing written.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mrd/runlog/runlog.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::TempDir;

std::string Mrd() { return test::Bin("mrd"); }
std::string Spec() { return std::string(MRD_SOURCE_DIR) + "/host/specs/paper.toml"; }

// Runs `mrd ARGS` and expects exit 2 with every fragment in the output.
CommandResult ExpectRefused(const std::string& args, const std::vector<std::string>& fragments) {
  const CommandResult r = test::Run(Mrd() + " " + args);
  EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
  for (const std::string& f : fragments) {
    EXPECT_NE(r.output.find(f), std::string::npos) << args << "\nlacks '" << f << "':\n"
                                                   << r.output;
  }
  return r;
}

// v1.csv (generated) and m.json (3 SEM iterations on it, paper spec) in a temporary directory.
class RobustCliTest : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    data_ = dir_->File("v1.csv");
    model_ = dir_->File("m.json");
    ASSERT_EQ(test::Run(Mrd() + " generate --profile v1 --out " + data_).status, 0);
    const CommandResult r = test::Run(Mrd() + " identify --data " + data_ + " --spec " + Spec() +
                                      " --max-iterations 3 --threads 1 --out " + model_);
    ASSERT_EQ(r.status, 0) << r.output;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  static TempDir* dir_;
  static std::string data_, model_;
  TempDir out_;
};

TempDir* RobustCliTest::dir_ = nullptr;
std::string RobustCliTest::data_, RobustCliTest::model_;

TEST_F(RobustCliTest, DirectoryGivenAsAnInputFileIsNamedAndRefused) {
  const std::string d = out_.File("D");
  fs::create_directory(d);
  const std::string o = out_.File("o");
  const std::string why = d + ": is a directory, not a regular file";
  for (const std::string& args : {
           "slice --in " + d + " --from 0 --to 1 --out " + o,
           "simulate --model " + model_ + " --data " + d,
           "simulate --model " + d + " --data " + data_,
           "identify --data " + d + " --out " + o,
           "identify --data " + data_ + " --validate " + d + " --out " + o,
           "identify --data " + data_ + " --spec " + d + " --out " + o,
           "import --in " + d + " --map t=t,x=x,v=v,E=E,f=f --out " + o,
           "report --model " + d + " --data " + data_ + " --out " + o,
           "report --model " + model_ + " --data " + d + " --out " + o,
           "compare --model " + d + " --data " + data_,
           "compare --model " + model_ + " --data " + d,
           "resid --model " + d + " --data " + data_,
           "resid --model " + model_ + " --data " + d,
           "export --model " + d + " --table " + o,
       }) {
    ExpectRefused(args, {"error: " + why});
  }
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, ExportRefusesAnIterationTheModelDoesNotHave) {
  const std::string o = out_.File("e.bin");
  for (const int k : {-1, -7, 4}) {
    ExpectRefused(fmt::format("export --model {} --iteration {} --table {}", model_, k, o),
                  {fmt::format("no iteration {}", k)});
  }
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, ExportOfAnIterationThatDoesNotReadTheInputSaysSo) {
  const std::string o = out_.File("e.bin");
  const CommandResult r = ExpectRefused("export --model " + model_ + " --iteration 0 --table " + o,
                                        {"iteration 0 (0 terms) does not read input 'E'"});
  EXPECT_EQ(r.output.find("has no input channel"), std::string::npos) << r.output;
  ExpectRefused("export --model " + model_ + " --input Q --table " + o,
                {"'Q' is not an input signal of the model"});
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, ImportRefusesARateThatLeavesFewerThanTwoRowsOrTooMany) {
  const std::string o = out_.File("o.csv");
  const std::string args = "import --in " + data_ + " --map t=t,x=x,v=v,E=E,f=f --out " + o;
  ExpectRefused(args + " --rate 1e-3", {"fewer than 2 rows"});
  ExpectRefused(args + " --rate 1e300", {"would write"});
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, FitSpencerRefusesAConstantForce) {
  std::string text = "t,x,v,E,f\n";
  for (int k = 0; k < 200; ++k) text += fmt::format("{:.3f},0,0,0,0\n", k * 1e-3);
  const std::string zeros = out_.Write("zeros.csv", text);
  const std::string o = out_.File("fs.toml");
  ExpectRefused("fit-spencer --data " + zeros + " --starts 0 --iterations 1 --out " + o,
                {"zeros.csv: output 'f' is constant (0)"});
  ExpectRefused("fit-spencer --data " + data_ + " --validate " + zeros +
                    " --starts 0 --iterations 1 --out " + o,
                {"zeros.csv: output 'f' is constant (0)", "nothing to score"});
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, NonFiniteOptionsAreRefused) {
  const std::string o = out_.File("o");
  const std::string imp = "import --in " + data_ + " --map t=t,x=x,v=v,E=E,f=f --out " + o;
  for (const std::string& args : {
           "slice --in " + data_ + " --from nan --to 1 --out " + o,
           "slice --in " + data_ + " --from 0 --to inf --out " + o,
           "export --model " + model_ + " --e-min nan --table " + o,
           "export --model " + model_ + " --e-max inf --table " + o,
           imp + " --rate nan",
           imp + " --cutoff nan",
           imp + " --max-jitter nan",
           "fit-spencer --data " + data_ + " --e-max nan --out " + o,
           "fit-spencer --data " + data_ + " --search-seconds nan --out " + o,
           "fit-spencer --data " + data_ + " --from nan --out " + o,
           "fit-spencer --data " + data_ + " --to -inf --out " + o,
           "identify --data " + data_ + " --target-j nan --out " + o,
       }) {
    ExpectRefused(args, {"is not a finite number"});
  }
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, GenerateNamesTheParameterFileWhenTheSimulationDiverges) {
  const std::string base = std::string(MRD_SOURCE_DIR) + "/hil/scenarios/nees-damper/plant.toml";
  const std::string text = test::FileBytes(base);
  ASSERT_NE(text.find("\nc0a = "), std::string::npos);
  const std::string o = out_.File("g.csv");
  for (const std::string key : {"c0a = 1e308", "eta = 1e9"}) {
    const std::string name = key.substr(0, key.find(' '));
    // The parameter file with the line of that key replaced (TOML refuses a repeated key).
    std::string edited;
    for (std::size_t at = 0; at < text.size();) {
      const std::size_t end = std::min(text.find('\n', at), text.size());
      const std::string line = text.substr(at, end - at);
      edited += (line.starts_with(name + " = ") ? key : line) + "\n";
      at = end + 1;
    }
    const std::string p = out_.Write(name + ".toml", edited);
    ExpectRefused("generate --profile v1 --params " + p + " --out " + o,
                  {"error: " + p + ": the simulation diverged: non-finite force", "at t = "});
  }
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, AnUnwritableOutputIsRefusedBeforeTheWork) {
  const std::string o = "/nonexistent_dir/o";
  const std::string why = o + ": cannot write into directory /nonexistent_dir";
  for (const std::string& args : {
           "identify --data " + data_ + " --spec " + Spec() + " --out " + o,
           "fit-spencer --data " + data_ + " --out " + o,
           "generate --profile v1 --out " + o,
           "slice --in " + data_ + " --from 0 --to 1 --out " + o,
           "import --in " + data_ + " --map t=t,x=x,v=v,E=E,f=f --out " + o,
           "simulate --model " + model_ + " --data " + data_ + " --out " + o,
           "export --model " + model_ + " --table " + o,
       }) {
    const CommandResult r = ExpectRefused(args, {"error: " + why});
    // Refused before any work: no identification or fit progress.
    EXPECT_EQ(r.output.find("iteration"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("fit-spencer:"), std::string::npos) << r.output;
  }
}

// report, compare and resid into DIR under a read-only parent: refused before the work (root
// writes anywhere, so the commands run as 'nobody' then).
TEST_F(RobustCliTest, AnUnwritableOutputDirectoryIsRefusedBeforeTheWork) {
  std::string prefix;
  if (geteuid() == 0) {
    if (test::Run("command -v setpriv").status != 0) GTEST_SKIP() << "no setpriv";
    prefix = "setpriv --reuid=65534 --regid=65534 --clear-groups ";
    for (const std::string& p : {dir_->File(""), data_, model_, out_.File("")}) {
      fs::permissions(p, fs::perms::all, fs::perm_options::add);
    }
  }
  const std::string parent = out_.File("ro");
  fs::create_directory(parent);
  fs::permissions(parent, fs::perms::owner_read | fs::perms::owner_exec);
  const std::string o = parent + "/out";
  for (const std::string& args : {
           "report --model " + model_ + " --data " + data_ + " --out " + o,
           "compare --model " + model_ + " --data " + data_ + " --out " + o,
           "resid --model " + model_ + " --data " + data_ + " --out " + o,
       }) {
    const CommandResult r = test::Run(prefix + Mrd() + " " + args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("error: --out " + o + ": cannot write into " + parent),
              std::string::npos)
        << args << "\n"
        << r.output;
    EXPECT_EQ(r.output.find("simulating"), std::string::npos) << r.output;  // no progress
  }
  fs::permissions(parent, fs::perms::owner_all);
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, ExportRefusesAKeywordAsTheSymbol) {
  const std::string h = out_.File("h.hpp");
  for (const std::string symbol : {"namespace", "a::int::b", "x::and", "1x", "a b"}) {
    ExpectRefused("export --model " + model_ + " --header " + h + " --symbol '" + symbol + "'",
                  {"error: --symbol: '" + symbol + "'"});
  }
  EXPECT_FALSE(fs::exists(h));
}

TEST_F(RobustCliTest, LogExportRefusesARepeatedField) {
  runlog::Header header;
  header.period_ns = 1000000;
  header.source = "robust_cli_test";
  header.fields = {{"t_ns", runlog::Type::kI64, "ns"}, {"force", runlog::Type::kF64, "N"}};
  const std::string log = out_.Write("run.mrdlog", runlog::EncodeHeader(header));
  const std::string csv = out_.File("log.csv");
  ASSERT_EQ(test::Run(Mrd() + " log export " + log + " --csv " + csv + " --fields t_ns").status, 0);
  fs::remove(csv);
  ExpectRefused("log export " + log + " --csv " + csv + " --fields t_ns,force,t_ns",
                {"--fields: field 't_ns' given twice"});
  EXPECT_FALSE(fs::exists(csv));
}

TEST_F(RobustCliTest, AnAbsurdlyLargeValueIsRefusedWithItsLine) {
  const std::string huge = out_.File("huge.csv");
  std::ofstream(huge) << "t,x,v,E,f\n0,0,0,0,0\n0.001,0,1,0,1e308\n0.002,0,2,0,1\n";
  const std::string o = out_.File("s.csv");
  ExpectRefused("simulate --model " + model_ + " --data " + huge + " --out " + o,
                {huge + ":3: column 'f': value 1e308 beyond +-1e100"});
  ExpectRefused("identify --data " + huge + " --spec " + Spec() + " --out " + out_.File("m.json"),
                {"value 1e308 beyond"});
  EXPECT_FALSE(fs::exists(o));
}

TEST_F(RobustCliTest, AModelFileWithAKeyGivenTwiceIsRefused) {
  std::string text = test::FileBytes(model_);
  const std::size_t at = text.find("\"selected\":");
  ASSERT_NE(at, std::string::npos);
  text.insert(at, "\"selected\": 0, ");  // the later one would silently win
  const std::string twice = out_.File("twice.json");
  std::ofstream(twice) << text;
  const std::string o = out_.File("s.csv");
  ExpectRefused("simulate --model " + twice + " --data " + data_ + " --out " + o,
                {twice, "key 'selected' given twice in one object"});
  ExpectRefused("export --model " + twice + " --table " + out_.File("e.bin"),
                {"key 'selected' given twice"});
  EXPECT_FALSE(fs::exists(o));
}

}  // namespace
}  // namespace mrd::host
