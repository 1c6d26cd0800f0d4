// Issue 13: the firmware holds the model to the table's operating envelope (label robust).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "host/test_util.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "support/fev_table.hpp"

namespace mrd::firmware {
namespace {

// f(k) = 0.5 f(k-1) + 0.1 f(k-1)^2 + 0.4 v(k)^3 + 0.1 E(k), normalised (f / 1000 N, E / 2.25 V,
// v / 15 cm/s): bounded on its data (|v| <= 15 cm/s), explodes for |v| of a few times that.
CoefficientTable CubicTable(bool envelope) {
  CoefficientTable t = test::FevTableSkeleton();
  Model& m = t.model;
  m.num_regressors = 3;
  m.regressors[0] = {0, Transform::kIdentity, 1.0};
  m.regressors[1] = {2, Transform::kIdentity, 1.0};
  m.regressors[2] = {1, Transform::kIdentity, 1.0};
  m.num_terms = 4;
  const Factor factors[] = {{0, 1, 1}, {0, 1, 2}, {1, 0, 3}, {2, 0, 1}};
  const double theta[] = {0.5, 0.1, 0.4, 0.1};
  for (std::size_t i = 0; i < 4; ++i) {
    m.terms[i].num_factors = 1;
    m.terms[i].factors[0] = factors[i];
    m.coefficients[i] = theta[i];
  }
  t.has_envelope = envelope;
  t.envelope[0] = {-900.0, 1000.0};
  t.envelope[1] = {0.0, 2.25};
  t.envelope[2] = {-15.0, 15.0};
  return t;
}

// Peak |f| of 2000 steps at velocity amplitude `amp` [cm/s]; counts non-finite forces.
double RunModel(BasicModelRuntime<double>& rt, double amp, int* non_finite) {
  double peak = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double f = rt.Step(amp * std::sin(0.02 * k), 0.0, 1.0);
    if (!std::isfinite(f)) ++*non_finite;
    peak = std::max(peak, std::fabs(f));
  }
  return peak;
}

TEST(EnvelopeRuntimeTest, HeldInputsKeepAnExplodingModelBounded) {
  BasicModelRuntime<double> free_run;
  ASSERT_EQ(free_run.Configure(CubicTable(true)), Error::kOk);
  ASSERT_EQ(free_run.SetEnvelope(false, 0.1), Error::kOk);
  int bad = 0;
  RunModel(free_run, 100.0, &bad);
  EXPECT_GT(bad, 0);  // without the envelope the model leaves the finite numbers
  EXPECT_EQ(free_run.input_excursions(), 0u);

  BasicModelRuntime<double> held;
  ASSERT_EQ(held.Configure(CubicTable(true)), Error::kOk);
  ASSERT_EQ(held.SetEnvelope(true, 0.1), Error::kOk);
  EXPECT_TRUE(held.envelope_active());
  bad = 0;
  const double peak = RunModel(held, 100.0, &bad);
  EXPECT_EQ(bad, 0);
  // The force is held to [-900 - 190, 1000 + 190] N.
  EXPECT_LE(peak, 1190.0 + 1e-9);
  EXPECT_GT(held.input_excursions(), 1000u);  // |v| > 18 cm/s most of the time
  EXPECT_LE(held.input_excursions(), 2000u);
  EXPECT_GT(held.force_excursions(), 0u);
}

TEST(EnvelopeRuntimeTest, InsideTheEnvelopeNothingChanges) {
  BasicModelRuntime<double> a, b;
  ASSERT_EQ(a.Configure(CubicTable(true)), Error::kOk);
  ASSERT_EQ(b.Configure(CubicTable(false)), Error::kOk);
  ASSERT_EQ(a.SetEnvelope(true, 0.0), Error::kOk);
  ASSERT_EQ(b.SetEnvelope(true, 0.0), Error::kOk);
  EXPECT_TRUE(a.envelope_active());
  EXPECT_FALSE(b.envelope_active());  // no envelope in the table
  for (int k = 0; k < 2000; ++k) {
    const double v = 14.0 * std::sin(0.02 * k);
    ASSERT_EQ(a.Step(v, 0.0, 1.0), b.Step(v, 0.0, 1.0)) << k;
  }
  EXPECT_EQ(a.input_excursions(), 0u);
  EXPECT_EQ(a.force_excursions(), 0u);
}

TEST(EnvelopeRuntimeTest, BadMarginIsRefused) {
  BasicModelRuntime<double> rt;
  ASSERT_EQ(rt.Configure(CubicTable(true)), Error::kOk);
  EXPECT_EQ(rt.SetEnvelope(true, -0.1), Error::kOutOfRange);
  EXPECT_EQ(rt.SetEnvelope(true, std::nan("")), Error::kOutOfRange);
}

// A number after "key": in the firmware's JSON summary (NaN when absent or null).
double JsonNumber(const std::string& json, const std::string& key) {
  const std::string tag = "\"" + key + "\": ";
  const auto at = json.find(tag);
  if (at == std::string::npos || json.compare(at + tag.size(), 4, "null") == 0) return std::nan("");
  return std::stod(json.substr(at + tag.size()));
}

// The dry-run plant (Spencer damper) driven far beyond the table's envelope: the built-in
// model with the envelope of the paper's identification set (|v| <= 15 cm/s).
TEST(EnvelopeDryRunTest, PlantFarBeyondTheEnvelopeStaysFiniteAndCounted) {
  test::TempDir dir;
  const std::string builtin = dir.File("builtin.bin"), table = dir.File("table.bin"),
                    config = dir.File("wide.toml");
  ASSERT_EQ(test::Run(test::Bin("mrd-firmware") + " --write-table " + builtin).status, 0);
  std::ifstream in(builtin, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  auto decoded = DecodeTable(bytes);
  ASSERT_TRUE(decoded.ok()) << ErrorName(decoded.error());
  CoefficientTable t = decoded.value();
  t.has_envelope = true;
  for (std::size_t c = 0; c < t.model.num_channels; ++c) {
    const std::string name = t.model.channel_names[c].data();
    t.envelope[c] = name == "v"   ? ChannelRange{-15.0, 15.0}
                    : name == "x" ? ChannelRange{-1.5, 1.5}
                    : name == "E" ? ChannelRange{0.0, 2.25}
                                  : ChannelRange{-1471.1, 1460.6};
  }
  const auto image = EncodeTable(t);
  ASSERT_TRUE(image.ok());
  std::ofstream(table, std::ios::binary)
      .write(reinterpret_cast<const char*>(image.value().data()),
             static_cast<std::streamsize>(image.value().size()));
  // 8 cm at 3 Hz: peak velocity 151 cm/s, ten times the envelope.
  std::ofstream(config) << "[simulation]\namplitude_cm = 8.0\nfrequency_hz = 3.0\n";
  const auto r = test::Run(test::Bin("mrd-firmware") + " --table " + table + " --config " + config +
                           " --dry-run 2 --lockstep --json");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(JsonNumber(r.output, "model_resets"), 0.0) << r.output;
  EXPECT_GT(JsonNumber(r.output, "envelope_excursions"), 500.0) << r.output;
  EXPECT_TRUE(std::isfinite(JsonNumber(r.output, "model_force_n"))) << r.output;
  EXPECT_TRUE(std::isfinite(JsonNumber(r.output, "last_command_v"))) << r.output;
  EXPECT_TRUE(std::isfinite(JsonNumber(r.output, "rms_model_error_n"))) << r.output;
  EXPECT_EQ(JsonNumber(r.output, "safe_entries"), 0.0) << r.output;  // still controlling
  // The envelope can be switched off ([envelope] hold = false): no excursions counted.
  std::ofstream(config, std::ios::app) << "[envelope]\nhold = false\n";
  const auto off = test::Run(test::Bin("mrd-firmware") + " --table " + table + " --config " +
                             config + " --dry-run 0.5 --lockstep --json");
  ASSERT_EQ(off.status, 0) << off.output;
  EXPECT_EQ(JsonNumber(off.output, "envelope_excursions"), 0.0);
  // A negative margin is a config error naming the key.
  std::ofstream(config, std::ios::trunc) << "[envelope]\nmargin = -1\n";
  const auto bad = test::Run(test::Bin("mrd-firmware") + " --table " + table + " --config " +
                             config + " --dry-run 0.1 --lockstep");
  EXPECT_EQ(bad.status, 2) << bad.output;
  EXPECT_NE(bad.output.find("margin"), std::string::npos) << bad.output;
}

}  // namespace
}  // namespace mrd::firmware
