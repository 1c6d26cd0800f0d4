// The harness's plants from outside data (labels hil, plant): an identified model as the plant
// ([plant] model = "narx") and the generated reference profiles ([excitation] kind =
// "profile"), checked against the host's own code paths (mrd export's runtime model, mrd
// generate's data set), and their refusals (FILE:LINE: reason).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "host/test_util.hpp"
#include "mrd/common/table.hpp"
#include "mrd/hil/plants/excitation_profile.hpp"
#include "mrd/hil/plants/model_plant.hpp"
#include "mrd/hil/scenario/scenario.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/profiles.hpp"
#include "mrd/host/table_export.hpp"

namespace mrd::hil {
namespace {

const std::string kPaperModel = MRD_SOURCE_DIR "/firmware/tables/paper_model.json";

std::string Write(const test::TempDir& dir, const std::string& name, const std::string& text) {
  const std::string path = dir.File(name);
  std::ofstream(path) << text;
  return path;
}

TableBytes Image(const Model& m) {
  CoefficientTable t;
  t.model = m;
  t.input_channel = static_cast<std::uint8_t>(m.ChannelIndex("E"));
  t.e_min = 0.0;
  t.e_max = 2.25;
  return host::TableImage(t);
}

// Every iteration of the paper model file: the harness builds the runtime model mrd export
// builds (channels, regressors, terms, coefficients), byte for byte in the table image.
TEST(ModelPlantTest, LoadsEveryIterationAsMrdExportDoes) {
  const host::ModelFile mf = host::LoadModelFile(kPaperModel);
  ASSERT_GT(mf.iterations.size(), 10U);
  for (const host::SemIteration& it : mf.iterations) {
    if (it.terms.empty()) continue;
    const Model want = host::ToRuntimeModel(mf, it.iteration);
    if (want.ChannelIndex("E") < 0) continue;  // a model without the command (early ones)
    PlantModel pm;
    std::string error;
    ASSERT_TRUE(LoadPlantModel(kPaperModel, it.iteration, 0.1, &pm, &error)) << error;
    EXPECT_EQ(pm.iteration, it.iteration);
    EXPECT_EQ(Image(pm.model), Image(want)) << "iteration " << it.iteration;
  }
  PlantModel pm;
  std::string error;
  ASSERT_TRUE(LoadPlantModel(kPaperModel, -1, 0.0, &pm, &error)) << error;
  EXPECT_EQ(pm.iteration, mf.selected);
  ASSERT_TRUE(pm.has_envelope);
  EXPECT_EQ(pm.lo[static_cast<std::size_t>(pm.v)], -15.0);  // margin 0: the data's range
  EXPECT_EQ(pm.hi[static_cast<std::size_t>(pm.v)], 15.0);
}

// On the V1 profile with the profile's own voltage, the model plant's force is the model's
// free run (mrd simulate's evaluator from a zero history) and tracks the Spencer force the
// model was identified to reproduce.
TEST(ModelPlantTest, PlaysTheModelOnTheMotion) {
  auto pm = std::make_shared<PlantModel>();
  std::string error;
  ASSERT_TRUE(LoadPlantModel(kPaperModel, -1, 0.1, pm.get(), &error)) << error;
  Trace trace;
  ASSERT_TRUE(ProfileTrace("v1", 1, SpencerParams::Paper(), &trace, &error)) << error;
  const host::Excitation ex = host::MakeExcitation("v1", 1);
  ModelPlant plant(pm, std::make_unique<TracePlant>(SpencerParams::Paper(), trace, 1e-3, 20));
  ModelRunner runner(pm->model);
  std::array<double, kMaxChannels> raw{};
  raw[static_cast<std::size_t>(pm->v)] = trace.v[0];
  EXPECT_DOUBLE_EQ(plant.Sample().force, runner.Step(std::span<const double>(raw.data(), 3)));
  double e2 = 0.0, f2 = 0.0;
  for (std::size_t k = 1; k < trace.x.size(); ++k) {
    const PlantSample probe = plant.Probe(ex.E[k]);
    const PlantSample s = plant.Step(ex.E[k]);
    EXPECT_DOUBLE_EQ(probe.force, s.force);
    raw[static_cast<std::size_t>(pm->v)] = trace.v[k];
    raw[static_cast<std::size_t>(pm->e)] = ex.E[k];
    ASSERT_DOUBLE_EQ(s.force, runner.Step(std::span<const double>(raw.data(), 3))) << k;
    e2 += (s.force - trace.demand[k]) * (s.force - trace.demand[k]);
    f2 += trace.demand[k] * trace.demand[k];
  }
  EXPECT_LT(std::sqrt(e2 / f2), 0.1);  // V1 is inside the identification range
  EXPECT_EQ(plant.Holds()->input_holds, 0U);
  EXPECT_EQ(plant.Holds()->force_holds, 0U);
}

// Motion beyond the identification range (|v| <= 15 cm/s, margin 10 %: 18 cm/s): every
// sample with |v| > 18 is held and counted, probes count nothing.
TEST(ModelPlantTest, HoldsInputsToTheEnvelopeAndCountsEveryHold) {
  auto pm = std::make_shared<PlantModel>();
  std::string error;
  ASSERT_TRUE(LoadPlantModel(kPaperModel, -1, 0.1, pm.get(), &error)) << error;
  PlantExcitation e;
  e.amplitude_cm = 2.0;  // peak v = 2 pi 2 Hz 2 cm = 25 cm/s
  e.frequency_hz = 2.0;
  ModelPlant plant(pm, std::make_unique<DamperPlantAdapter>(SpencerParams::Paper(), e, 1e-3));
  std::uint64_t beyond = std::fabs(plant.Sample().v) > 18.0 ? 1 : 0;
  for (int k = 0; k < 1000; ++k) {
    plant.Probe(2.25);
    const PlantSample s = plant.Step(1.0);
    if (std::fabs(s.v) > 18.0) ++beyond;
    ASSERT_TRUE(std::isfinite(s.force));
  }
  EXPECT_GT(beyond, 100U);
  EXPECT_EQ(plant.Holds()->input_holds, beyond);
}

// The profile excitation is `mrd generate`'s data set, sample by sample: x, v and the demand
// against the CSV the command writes (10 significant digits), for every profile.
TEST(ExcitationProfileTest, EqualsMrdGenerateSampleBySample) {
  test::TempDir dir;
  for (const std::string profile : {"v1", "v2", "v3"}) {
    const std::string csv = dir.File(profile + ".csv");
    ASSERT_EQ(
        test::Run(test::Bin("mrd") + " generate --profile " + profile + " --seed 3 --out " + csv)
            .status,
        0);
    const host::DataSet data = host::ReadCsv(csv);
    Trace trace;
    std::string error;
    ASSERT_TRUE(ProfileTrace(profile, 3, SpencerParams::Paper(), &trace, &error)) << error;
    ASSERT_EQ(trace.x.size(), data.rows()) << profile;
    const auto near = [](double a, double b) {
      return std::fabs(a - b) <= 1e-9 * std::fabs(b) + 1e-12;
    };
    for (std::size_t k = 0; k < data.rows(); ++k) {
      ASSERT_TRUE(near(trace.x[k], data.Column("x")[k])) << profile << " row " << k;
      ASSERT_TRUE(near(trace.v[k], data.Column("v")[k])) << profile << " row " << k;
      ASSERT_TRUE(near(trace.demand[k], data.Column("f")[k])) << profile << " row " << k;
    }
  }
  Trace t;
  std::string error;
  EXPECT_FALSE(ProfileTrace("v9", 1, SpencerParams::Paper(), &t, &error));
  EXPECT_NE(error.find("unknown profile 'v9'"), std::string::npos) << error;
}

// Scenario keys: profile excitation and model plant, and each refusal with its line.
class PlantScenarioTest : public ::testing::Test {
 protected:
  test::TempDir dir;
  std::string Load(const std::string& text, Scenario* s) {
    std::string error;
    const std::string path = Write(dir, "s.toml", text);
    return LoadScenario(path, s, &error) ? "" : error.substr(error.find(".toml:") + 5);
  }
  std::string model_key() const { return "file = \"" + kPaperModel + "\"\n"; }
};

TEST_F(PlantScenarioTest, ReadsProfileAndNarxKeys) {
  Scenario s;
  ASSERT_EQ(Load("[plant]\nmodel = \"narx\"\n" + model_key() +
                     "iteration = 20\n[excitation]\nkind = \"profile\"\nprofile = \"v3\"\n"
                     "seed = 7\n",
                 &s),
            "");
  EXPECT_EQ(s.excitation, ExcitationKind::kProfile);
  EXPECT_EQ(s.profile, "v3");
  EXPECT_EQ(s.profile_seed, 7U);
  ASSERT_NE(s.plant_model, nullptr);
  EXPECT_EQ(s.plant_model->iteration, 20);
  EXPECT_EQ(s.plant_model->model.num_terms, 15);  // the paper run's iteration 20 (monotone_in)
}

TEST_F(PlantScenarioTest, RefusesBadInputWithItsLine) {
  Scenario s;
  EXPECT_EQ(Load("[excitation]\nkind = \"profile\"\nprofile = \"v9\"\n", &s).substr(0, 3), ":3:");
  EXPECT_NE(Load("[excitation]\nkind = \"profile\"\n", &s).find(":2: kind = \"profile\" needs"),
            std::string::npos);
  EXPECT_NE(Load("[excitation]\nkind = \"csv\"\nfile = \"a.csv\"\nseed = 2\n", &s)
                .find(":4: 'profile' and 'seed' need"),
            std::string::npos);
  EXPECT_NE(Load("[plant]\nmodel = \"narx\"\n", &s).find(":2: model = \"narx\" needs 'file'"),
            std::string::npos);
  EXPECT_NE(Load("[plant]\n" + model_key(), &s).find(":2: 'file' needs [plant] model = \"narx\""),
            std::string::npos);
  const std::string missing = Load("[plant]\nmodel = \"narx\"\nfile = \"nope.json\"\n", &s);
  EXPECT_NE(missing.find(":3: plant model: "), std::string::npos) << missing;
  EXPECT_NE(missing.find("nope.json"), std::string::npos) << missing;
  const std::string iteration =
      Load("[plant]\nmodel = \"narx\"\n" + model_key() + "iteration = 99\n", &s);
  EXPECT_NE(iteration.find(":4: plant model: "), std::string::npos) << iteration;
  EXPECT_NE(iteration.find("no iteration 99"), std::string::npos) << iteration;
}

// A model reading a signal the plant does not have (an acceleration 'a'), one without the
// command, and a file that is not JSON: refused with the reason.
TEST_F(PlantScenarioTest, RefusesModelsThePlantCannotPlay) {
  std::ifstream in(kPaperModel);
  nlohmann::json j = nlohmann::json::parse(in);
  for (auto& r : j["spec"]["regressor"]) {
    if (r["signal"] == "v") r["signal"] = "a";
  }
  for (auto& c : j["channels"]) {
    if (c["name"] == "v") c["name"] = "a";
  }
  Write(dir, "accel.json", j.dump());
  Scenario s;
  const std::string a = Load("[plant]\nmodel = \"narx\"\nfile = \"accel.json\"\n", &s);
  EXPECT_NE(a.find(":3: plant model: "), std::string::npos) << a;
  EXPECT_NE(a.find("reads signal 'a', which the plant cannot supply"), std::string::npos) << a;
  // The selected iteration without its terms in E (u1).
  j = nlohmann::json::parse(std::ifstream(kPaperModel));
  for (auto& it : j["iterations"]) {
    if (it["iteration"] != j["selected"]) continue;
    nlohmann::json kept = nlohmann::json::array();
    for (const auto& t : it["terms"]) {
      bool e = false;
      for (const auto& f : t["factors"]) e = e || f["regressor"] == "u1";
      if (!e) kept.push_back(t);
    }
    ASSERT_GT(kept.size(), 0U);
    it["terms"] = kept;
  }
  Write(dir, "no_e.json", j.dump());
  const std::string no_e = Load("[plant]\nmodel = \"narx\"\nfile = \"no_e.json\"\n", &s);
  EXPECT_NE(no_e.find(":3: plant model: "), std::string::npos) << no_e;
  EXPECT_NE(no_e.find("does not read the command 'E'"), std::string::npos) << no_e;
  Write(dir, "bad.json", "{\"format\": ");
  const std::string bad = Load("[plant]\nmodel = \"narx\"\nfile = \"bad.json\"\n", &s);
  EXPECT_NE(bad.find(":3: plant model: "), std::string::npos) << bad;
  EXPECT_NE(bad.find("bad model file"), std::string::npos) << bad;
}

}  // namespace
}  // namespace mrd::hil
