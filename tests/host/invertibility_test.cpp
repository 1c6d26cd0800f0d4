// Invertibility in the command as a checked model property (host/include/mrd/host/
// invertibility.hpp): the check over the data's states and the envelope grid, a deliberately
// non-monotone model through `mrd simulate`, `mrd compare` and `mrd export` (refused, exit 2,
// the share and the worst state named; --allow-non-monotone exports it with a warning), the
// table's invertibility record, and the search's spec key monotone_in.
#include "mrd/host/invertibility.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "mrd/common/table.hpp"
#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem.hpp"
#include "sem_test_util.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

constexpr const char* kSpec = R"(output = "f"
[[regressor]]
name = "y"
signal = "f"
powers = [1]
delays = [1]
[[regressor]]
name = "u1"
signal = "E"
powers = [1]
delays = [0]
[[regressor]]
name = "w"
signal = "v"
transform = "tanh"
scale = 0.1
powers = [1]
delays = [0]
)";

// y = 0.6 y(k-1) + 0.5 w(k) + c E(k) w(k) + d E(k) (w = tanh(v / 0.1), normalised units):
// with c > 0, d = 0 the force rises with E in the direction of v everywhere; with d < 0 it
// falls as E rises where v > 0 and |w| is small against |d| / c (slow positive velocities).
ModelFile HandModel(double c, double d) {
  ModelFile m;
  m.spec = ParseSemSpec(kSpec, "hand.toml");
  m.channels = {{"f", 0.0, 1500.0, true, -1500.0, 1500.0},
                {"E", 0.0, 2.25, true, 0.0, 2.25},
                {"v", 0.0, 15.0, true, -15.0, 15.0}};
  SemIteration it;
  it.iteration = 0;
  it.terms = {ParseTerm(m.spec, "y(k-1)"), ParseTerm(m.spec, "w(k)"),
              ParseTerm(m.spec, "u1(k)*w(k)"), ParseTerm(m.spec, "u1(k)")};
  it.coefficients = {0.6, 0.5, c, d};
  m.iterations = {it};
  m.selected = 0;
  m.selection_rule = "hand-made";
  return m;
}

DataSet Sweep() {
  std::vector<double> x, v, E, f;
  for (int k = 0; k < 3000; ++k) {
    v.push_back(14.0 * std::sin(0.004 * k));
    x.push_back(0.0);
    E.push_back(1.125 + 1.1 * std::sin(0.0013 * k));
    f.push_back(900.0 * std::tanh(v.back() / 1.5) * (0.3 + E.back() / 2.25));
  }
  return test::MakeDataSet("sweep.csv", {"x", "v", "E", "f"}, {x, v, E, f});
}

TEST(InvertibilityCheckTest, MonotoneModelPassesOnDataAndGrid) {
  const ModelFile m = HandModel(0.4, 0.0);
  const DataSet d = Sweep();
  const InvertibilityReport r = CheckModelInvertibility(m, 0, std::span<const DataSet>(&d, 1));
  EXPECT_TRUE(r.pass()) << InvertibilitySummary(r);
  EXPECT_EQ(r.visited_states, d.rows() - 1);  // from the largest delay on
  // Grid: 20 velocities x 9 forces fed back, the command with no past (one value).
  EXPECT_EQ(r.grid_states, static_cast<std::size_t>(kGridVelocity * kGridOther));
  EXPECT_EQ(r.share_percent(), 0.0);
}

TEST(InvertibilityCheckTest, FallingForceIsCountedWithItsWorstState) {
  const ModelFile m = HandModel(0.4, -0.1);
  const DataSet d = Sweep();
  const InvertibilityReport r = CheckModelInvertibility(m, 0, std::span<const DataSet>(&d, 1));
  EXPECT_FALSE(r.pass());
  EXPECT_GT(r.failing(), 0u);
  EXPECT_LT(r.failing(), r.states());  // only slow positive velocities
  EXPECT_EQ(r.not_one_to_one, 0u);     // straight lines in E: one-to-one, falling
  EXPECT_EQ(r.non_monotone, r.failing());
  // The worst: the lowest positive velocity, where 0.4 w - 0.1 is most negative.
  ASSERT_TRUE(r.has_worst);
  EXPECT_LT(r.worst.verdict.worst_slope, 0.0);
  const std::string s = InvertibilitySummary(r);
  EXPECT_NE(s.find("states fail"), std::string::npos) << s;
  EXPECT_NE(s.find("worst: v = "), std::string::npos) << s;
  EXPECT_NE(s.find("dE * sign(v) = -"), std::string::npos) << s;
  // A narrower command range: the slopes (lines in E) are the same, the flat tolerance (a force
  // share over the range) is 4.5 times wider, so fewer states but still some fail.
  const InvertibilityReport narrow =
      CheckModelInvertibility(m, 0, std::span<const DataSet>(&d, 1), std::pair{0.5, 1.0});
  EXPECT_EQ(narrow.e_min, 0.5);
  EXPECT_NEAR(narrow.tolerance, r.tolerance * 2.25 / 0.5, 1e-9 * r.tolerance);
  EXPECT_GT(narrow.failing(), 0u);
  EXPECT_LT(narrow.failing(), r.failing());
}

// The deliberately non-monotone model through the CLI.
class NonMonotoneCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const DataSet d = Sweep();
    WriteCsv(dir_.File("sweep.csv"), d.names, d.columns);
    ModelFile bad = HandModel(0.4, -0.1);
    bad.identification_data = {dir_.File("sweep.csv")};
    SaveModelFile(bad, dir_.File("bad.json"));
    ModelFile good = HandModel(0.4, 0.0);
    good.identification_data = {dir_.File("sweep.csv")};
    SaveModelFile(good, dir_.File("good.json"));
  }
  std::string Mrd(const std::string& args) const { return test::Bin("mrd") + " " + args; }
  test::TempDir dir_;
};

TEST_F(NonMonotoneCliTest, SimulateAndCompareNameTheShare) {
  const auto s = test::Run(
      Mrd("simulate --model " + dir_.File("bad.json") + " --data " + dir_.File("sweep.csv")));
  ASSERT_EQ(s.status, 0) << s.output;
  EXPECT_NE(s.output.find("invertibility in E on [0, 2.25]: "), std::string::npos) << s.output;
  EXPECT_NE(s.output.find("warning: "), std::string::npos) << s.output;
  EXPECT_NE(s.output.find("fall as E rises in the dissipative direction"), std::string::npos)
      << s.output;
  // stdout alone (Run adds 2>&1 after the group): the JSON without the warning.
  const auto j = test::Run("{ " +
                           Mrd("simulate --json --model " + dir_.File("bad.json") + " --data " +
                               dir_.File("sweep.csv")) +
                           " 2>/dev/null; }");
  ASSERT_EQ(j.status, 0) << j.output;
  const auto json = nlohmann::json::parse(j.output);
  EXPECT_FALSE(json["invertibility"]["pass"].get<bool>());
  EXPECT_GT(json["invertibility"]["share_percent"].get<double>(), 0.0);
  const auto c = test::Run(Mrd("compare --model " + dir_.File("good.json") + "," +
                               dir_.File("bad.json") + " --data " + dir_.File("sweep.csv")));
  ASSERT_EQ(c.status, 0) << c.output;
  EXPECT_NE(c.output.find("not invertible"), std::string::npos) << c.output;  // the column
  EXPECT_NE(c.output.find("bad.json on "), std::string::npos) << c.output;    // the warning
  EXPECT_EQ(c.output.find("good.json on " + dir_.File("sweep.csv") + ": invertibility"),
            std::string::npos)
      << c.output;
}

TEST_F(NonMonotoneCliTest, ExportRefusesItUnlessAllowed) {
  const std::string table = dir_.File("bad.bin");
  const auto r = test::Run(Mrd("export --model " + dir_.File("bad.json") + " --table " + table));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("error: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not invertible"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("states fail ("), std::string::npos) << r.output;  // the share
  EXPECT_NE(r.output.find("worst: v = "), std::string::npos) << r.output;    // the state
  EXPECT_NE(r.output.find("--allow-non-monotone"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(table));

  const auto a = test::Run(
      Mrd("export --allow-non-monotone --model " + dir_.File("bad.json") + " --table " + table));
  ASSERT_EQ(a.status, 0) << a.output;
  EXPECT_NE(a.output.find("warning: "), std::string::npos) << a.output;
  EXPECT_NE(a.output.find("exported although not invertible"), std::string::npos) << a.output;
  const std::string bytes = test::FileBytes(table);
  const auto d =
      DecodeTable(std::span(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
  ASSERT_TRUE(d.ok()) << ErrorName(d.error());
  EXPECT_TRUE(d.value().has_invertibility);
  EXPECT_GT(d.value().invertibility.failing, 0u);
  EXPECT_LT(d.value().invertibility.worst_slope, 0.0);

  const auto g = test::Run(
      Mrd("export --model " + dir_.File("good.json") + " --table " + dir_.File("good.bin")));
  ASSERT_EQ(g.status, 0) << g.output;
  EXPECT_EQ(g.output.find("warning"), std::string::npos) << g.output;
  const std::string gb = test::FileBytes(dir_.File("good.bin"));
  const auto gd =
      DecodeTable(std::span(reinterpret_cast<const std::uint8_t*>(gb.data()), gb.size()));
  ASSERT_TRUE(gd.ok());
  EXPECT_TRUE(gd.value().has_invertibility);
  EXPECT_EQ(gd.value().invertibility.failing, 0u);
  // The data's states and the grid (the data file named in the model file is still there).
  EXPECT_EQ(gd.value().invertibility.states, 2999u + kGridVelocity * kGridOther);
}

// The search with monotone_in: the same candidates, the model that falls with E is never
// accepted, and the rejections are counted.
TEST(MonotoneSearchTest, RequiredPropertyHoldsForEveryRecordedIteration) {
  // Data of the non-monotone model itself, run free: an unconstrained search finds it.
  const ModelFile truth = HandModel(0.4, -0.1);
  DataSet d = Sweep();
  std::vector<double> y;
  SimulateModel(truth, 0, d, &y);
  d.columns[4] = y;  // f
  test::Gauss noise(7);
  for (double& f : d.columns[4]) f += 2.0 * noise();
  std::string text = std::string(kSpec) + "[algorithm]\nmax_iterations = 6\n";
  const SemSpec free = ParseSemSpec(text, "free.toml");
  const SemSpec held = ParseSemSpec(text + "monotone_in = \"E\"\n", "held.toml");
  EXPECT_EQ(held.monotone_in, "E");
  SemOptions o;
  o.threads = 2;
  const std::vector<DataSet> data{d};
  const SemResult rf = Identify(free, data, {}, o);
  const SemResult rh = Identify(held, data, {}, o);
  auto model_file = [&](const SemSpec& s, const SemResult& r) {
    ModelFile m = MakeModelFile(s, r);
    return m;
  };
  const ModelFile mf = model_file(free, rf), mh = model_file(held, rh);
  const InvertibilityReport a = CheckModelInvertibility(mf, mf.selected, data);
  const InvertibilityReport b = CheckModelInvertibility(mh, mh.selected, data);
  EXPECT_FALSE(a.pass()) << InvertibilitySummary(a);  // the data's own falling force
  EXPECT_TRUE(b.pass()) << InvertibilitySummary(b);
  int rejected = 0;
  for (const SemIteration& it : rh.iterations) {
    EXPECT_TRUE(it.monotone.checked);
    if (it.iteration == rh.selected) {
      EXPECT_TRUE(it.monotone.pass) << it.monotone.worst;
    }
    rejected += it.monotone_rejected;
  }
  EXPECT_GT(rejected, 0);
  for (const SemIteration& it : rf.iterations) EXPECT_FALSE(it.monotone.checked);
}

TEST(MonotoneSearchTest, SpecKeyMustNameAnInputSignal) {
  for (const char* bad :
       {"monotone_in = \"f\"", "monotone_in = \"q\"", "monotone_in = \"\"", "monotone_in = 3"}) {
    const std::string text = std::string(kSpec) + "[algorithm]\n" + bad + "\n";
    try {
      ParseSemSpec(text, "bad.toml");
      ADD_FAILURE() << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.toml:"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("monotone_in"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace mrd::host
