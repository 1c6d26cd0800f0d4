// The spec stored in a model file: read back through the spec file's own validation, with full
// precision, and a tampered stored spec refused with the model file's name.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem.hpp"
#include "sem_test_util.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

using nlohmann::json;

const std::string kSaturating = std::string(MRD_SOURCE_DIR) + "/host/specs/paper-saturating.toml";

// A saved model file of a short identification under the saturating spec (tanh regressors,
// stress section, initial terms), as JSON.
json SavedModel() {
  const SemSpec spec = LoadSemSpec(kSaturating);
  SemOptions o;
  o.max_iterations = 2;
  const std::vector<DataSet> id{test::DamperData("identification", 3001)};
  const SemResult r = Identify(spec, id, {}, o);
  const std::string path = ::testing::TempDir() + "/model_file_spec.json";
  SaveModelFile(MakeModelFile(spec, r), path);
  std::ifstream in(path);
  return json::parse(in);
}

std::string Write(const json& j, const std::string& name) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << j.dump(2);
  return path;
}

std::string LoadError(const json& j, const std::string& name) {
  try {
    LoadModelFile(Write(j, name));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ModelFileSpecTest, TheStoredSpecReadsBackAsTheSpecFileReadsIt) {
  const json saved = SavedModel();
  const ModelFile back = LoadModelFile(Write(saved, "model_file_spec_back.json"));
  const SemSpec file = LoadSemSpec(kSaturating);
  ASSERT_EQ(back.spec.regressors.size(), file.regressors.size());
  for (std::size_t i = 0; i < file.regressors.size(); ++i) {
    EXPECT_EQ(back.spec.regressors[i].name, file.regressors[i].name);
    EXPECT_EQ(back.spec.regressors[i].transform, file.regressors[i].transform);
    EXPECT_EQ(back.spec.regressors[i].delays, file.regressors[i].delays);
  }
  EXPECT_EQ(back.spec.initial, file.initial);
  EXPECT_EQ(back.spec.stress.enabled, file.stress.enabled);
  EXPECT_EQ(back.spec.stress.force_bound, file.stress.force_bound);
  EXPECT_EQ(json::parse(ModelFileToJson(back)), saved);
}

TEST(ModelFileSpecTest, ANumberKeepsEveryBit) {
  json j = SavedModel();
  const double floor = 0.1 + 0.2;  // 0.30000000000000004: needs all 17 digits
  j["spec"]["cost"]["floor"] = floor;
  const ModelFile back = LoadModelFile(Write(j, "model_file_spec_bits.json"));
  EXPECT_EQ(std::memcmp(&back.spec.floor, &floor, sizeof floor), 0) << back.spec.floor;
}

TEST(ModelFileSpecTest, ATamperedSpecIsRefusedNamingTheFileAndTheKey) {
  const json saved = SavedModel();
  json wrong_type = saved;
  wrong_type["spec"]["limits"]["max_factors"] = "three";
  const std::string e1 = LoadError(wrong_type, "spec_wrong_type.json");
  EXPECT_NE(e1.find("spec_wrong_type.json"), std::string::npos) << e1;
  EXPECT_NE(e1.find("bad spec in model file"), std::string::npos) << e1;
  EXPECT_NE(e1.find("max_factors"), std::string::npos) << e1;

  json huge = saved;
  huge["spec"]["algorithm"]["max_iterations"] = 18446744073709551615ULL;
  const std::string e2 = LoadError(huge, "spec_huge.json");
  EXPECT_NE(e2.find("max_iterations"), std::string::npos) << e2;

  json not_object = saved;
  not_object["spec"] = 5;
  const std::string e3 = LoadError(not_object, "spec_not_object.json");
  EXPECT_NE(e3.find("'spec' must be an object"), std::string::npos) << e3;

  json null_value = saved;
  null_value["spec"]["cost"]["floor"] = nullptr;
  const std::string e4 = LoadError(null_value, "spec_null.json");
  EXPECT_NE(e4.find("floor"), std::string::npos) << e4;

  json unknown = saved;
  unknown["spec"]["limits"]["max_factros"] = 3;
  const std::string e5 = LoadError(unknown, "spec_unknown.json");
  EXPECT_NE(e5.find("max_factros"), std::string::npos) << e5;
}

}  // namespace
}  // namespace mrd::host
