// Channels go by name, never by position. `mrd export` on a model file whose channels are
// stored in another order than the table's (an input the selected iteration does not read
// before the ones it reads; v before E) gives every table channel its own envelope, scale and
// regressors, and the inverted input by name: the paper model with its channels moved around
// exports the same table (byte for byte where the table's order is the same, the same ranges,
// scales and forces by name otherwise) and simulates a run as the paper model does. `mrd
// import` takes each output column from the input column its --map names, in whatever order
// the file and the map list them.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "mrd/common/model.hpp"
#include "mrd/common/table.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/import.hpp"
#include "mrd/host/model_file.hpp"
#include "test_util.hpp"

namespace mrd::host {
namespace {

using nlohmann::json;

const std::string kPaperModel = std::string(MRD_SOURCE_DIR) + "/firmware/tables/paper_model.json";

json PaperModel() {
  std::ifstream in(kPaperModel);
  return json::parse(in);
}

// The paper model with a displacement regressor the iterations never read inserted as spec
// regressor `at`, and its channel (range [-2.5, 2.5] cm) at the place the spec's signal order
// gives it.
json WithUnreadDisplacement(json m, std::size_t at) {
  json& regs = m["spec"]["regressor"];
  regs.insert(regs.begin() + static_cast<std::ptrdiff_t>(at), json{{"delays", {0}},
                                                                   {"name", "ux"},
                                                                   {"powers", {1}},
                                                                   {"signal", "x"},
                                                                   {"transform", "identity"}});
  return m;
}

// The spec regressors reordered by name (the channels follow: output, then the signals in the
// order the regressors first name them, as mrd identify writes them).
json Reordered(json m, const std::vector<std::string>& names) {
  json regs = json::array();
  for (const std::string& n : names) {
    for (const json& r : m["spec"]["regressor"]) {
      if (r["name"] == n) regs.push_back(r);
    }
  }
  m["spec"]["regressor"] = regs;
  return m;
}

// Channels in spec signal order, from the paper's (plus x when a regressor reads it).
json WithChannelsInSignalOrder(json m) {
  json by_name = json::object();
  for (const json& c : m["channels"]) by_name[c["name"].get<std::string>()] = c;
  by_name["x"] = {{"name", "x"}, {"offset", 0.25}, {"scale", 3.0}, {"min", -2.5}, {"max", 2.5}};
  json channels = json::array({by_name[m["spec"]["output"].get<std::string>()]});
  std::vector<std::string> seen{m["spec"]["output"].get<std::string>()};
  for (const json& r : m["spec"]["regressor"]) {
    const std::string s = r["signal"];
    if (std::find(seen.begin(), seen.end(), s) != seen.end()) continue;
    seen.push_back(s);
    channels.push_back(by_name[s]);
  }
  m["channels"] = channels;
  return m;
}

// `mrd export` of model text; the table file's decoded table.
CoefficientTable Export(const test::TempDir& dir, const std::string& name, const json& model) {
  const std::string path = dir.Write(name + ".json", model.dump(1));
  const std::string table = dir.File(name + ".bin");
  const auto r = test::Run(test::Bin("mrd") + " export --model " + path + " --table " + table);
  EXPECT_EQ(r.status, 0) << r.output;
  const std::string bytes = test::FileBytes(table);
  const auto decoded =
      DecodeTable(std::span(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
  EXPECT_TRUE(decoded.ok()) << name;
  return decoded.ok() ? decoded.value() : CoefficientTable{};
}

// A model file's channel by name.
json Channel(const json& model, const std::string& name) {
  for (const json& c : model["channels"]) {
    if (c["name"] == name) return c;
  }
  return json();
}

// Every table channel's envelope and scale are the model file's for that name.
void ExpectRangesByName(const CoefficientTable& t, const json& model) {
  ASSERT_TRUE(t.has_envelope);
  for (std::size_t c = 0; c < t.model.num_channels; ++c) {
    const std::string name = t.model.channel_names[c].data();
    const json ch = Channel(model, name);
    ASSERT_FALSE(ch.is_null()) << name;
    EXPECT_EQ(t.envelope[c].min, ch["min"].get<double>()) << name;
    EXPECT_EQ(t.envelope[c].max, ch["max"].get<double>()) << name;
    EXPECT_EQ(t.model.scales[c].scale, ch["scale"].get<double>()) << name;
    EXPECT_EQ(t.model.scales[c].offset, ch["offset"].get<double>()) << name;
  }
}

// The model's forces [N] over a made-up run (v, E by name; x, when a channel, held at 1 cm).
std::vector<double> Forces(const CoefficientTable& t) {
  ModelRunner runner(t.model);
  std::array<double, kMaxChannels> raw{};
  std::vector<double> f;
  for (int k = 0; k < 400; ++k) {
    for (std::size_t c = 0; c < t.model.num_channels; ++c) {
      const std::string n = t.model.channel_names[c].data();
      raw[c] = n == "v"   ? 12.0 * std::sin(0.05 * k)
               : n == "E" ? 1.1 + std::sin(0.013 * k)
               : n == "x" ? 1.0
                          : 0.0;
    }
    f.push_back(runner.Step(std::span<const double>(raw.data(), t.model.num_channels)));
  }
  return f;
}

std::string Image(const CoefficientTable& t) {
  const auto r = EncodeTable(t);
  return r.ok() ? std::string(r.value().begin(), r.value().end()) : std::string();
}

TEST(ExportChannelOrderTest, AnUnreadChannelBeforeTheReadOnesChangesNothingInTheTable) {
  test::TempDir dir;
  const json paper = PaperModel();
  const json moved = WithChannelsInSignalOrder(WithUnreadDisplacement(paper, 1));
  ASSERT_EQ(moved["channels"][1]["name"], "x");  // f, x, E, v in the file; f, E, v in the table
  const CoefficientTable a = Export(dir, "paper", paper);
  const CoefficientTable b = Export(dir, "moved", moved);
  ExpectRangesByName(b, moved);
  EXPECT_EQ(b.model.num_channels, 3);
  EXPECT_EQ(std::string(b.model.channel_names[b.input_channel].data()), "E");
  EXPECT_TRUE(Image(a) == Image(b)) << "the two tables differ";
}

TEST(ExportChannelOrderTest, ChannelsInAnotherOrderKeepTheirRangesScalesInputAndForces) {
  test::TempDir dir;
  const json paper = PaperModel();
  // v's regressors first, then x (unread), then E: f, v, x, E in the file; f, v, E in the table.
  const json moved = WithChannelsInSignalOrder(
      WithUnreadDisplacement(Reordered(paper, {"y", "u2", "u3", "u1"}), 3));
  ASSERT_EQ(moved["channels"][1]["name"], "v");
  ASSERT_EQ(moved["channels"][2]["name"], "x");
  const CoefficientTable a = Export(dir, "paper", paper);
  const CoefficientTable b = Export(dir, "moved", moved);
  ExpectRangesByName(b, moved);
  ASSERT_EQ(b.model.num_channels, 3);
  EXPECT_EQ(std::string(b.model.channel_names[1].data()), "v");
  EXPECT_EQ(std::string(b.model.channel_names[b.input_channel].data()), "E");
  EXPECT_EQ(b.input_channel, 2);
  const std::vector<double> fa = Forces(a), fb = Forces(b);
  ASSERT_EQ(fa.size(), fb.size());
  for (std::size_t k = 0; k < fa.size(); ++k) ASSERT_NEAR(fa[k], fb[k], 1e-9 * 1500.0) << k;
}

// `mrd simulate` (and report, compare) feeds each model channel its data column by name: the
// moved model simulates the paper's run exactly as the paper model does.
TEST(ExportChannelOrderTest, SimulationFeedsEachChannelItsOwnColumn) {
  test::TempDir dir;
  const std::string data = dir.File("v1.csv");
  const auto g = test::Run(test::Bin("mrd") + " generate --profile v1 --seed 1 --out " + data);
  ASSERT_EQ(g.status, 0) << g.output;
  const DataSet ds = ReadCsv(data);
  const json paper = PaperModel();
  const json moved = WithChannelsInSignalOrder(
      WithUnreadDisplacement(Reordered(paper, {"y", "u2", "u3", "u1"}), 3));
  const ModelFile a = LoadModelFile(dir.Write("paper.json", paper.dump(1)));
  const ModelFile b = LoadModelFile(dir.Write("moved.json", moved.dump(1)));
  std::vector<double> ya, yb;
  const SimMetrics ma = SimulateModel(a, a.selected, ds, &ya);
  const SimMetrics mb = SimulateModel(b, b.selected, ds, &yb);
  EXPECT_GT(ma.fit_percent, 90.0);
  EXPECT_NEAR(mb.fit_percent, ma.fit_percent, 1e-9);
  ASSERT_EQ(ya.size(), yb.size());
  for (std::size_t k = 0; k < ya.size(); ++k) ASSERT_NEAR(ya[k], yb[k], 1e-6) << k;
}

// ---- mrd import ----

// 2000 rows at 1 kHz, columns in the file's order Force, Volt, time, Disp, Vel; each signal
// around its own level so that a swap shows: x ~ 1 cm, v ~ 20 cm/s, E ~ 1.5 V, f ~ 300 N.
std::string ShuffledCsv() {
  std::string s = "Force,Volt,time,Disp,Vel\n";
  for (int k = 0; k < 2000; ++k) {
    const double t = k * 1e-3, w = std::sin(2.0 * M_PI * 5.0 * t);
    s += fmt::format("{:.6f},{:.6f},{:.3f},{:.6f},{:.6f}\n", 300.0 + 10.0 * w, 1.5 + 0.1 * w, t,
                     1.0 + 0.05 * w, 20.0 + w);
  }
  return s;
}

double Mean(const std::vector<double>& c) {
  double s = 0.0;
  for (const double v : c) s += v;
  return c.empty() ? 0.0 : s / static_cast<double>(c.size());
}

TEST(ImportColumnOrderTest, EachOutputTakesTheColumnItsMapNames) {
  test::TempDir dir;
  ImportOptions o;
  o.in_path = dir.Write("shuffled.csv", ShuffledCsv());
  o.map = ParseImportMap("f=Force,t=time,E=Volt,v=Vel,x=Disp");
  o.scale = {{"f", 2.0}};  // by name: f only
  const ImportResult r = Import(o);
  ASSERT_EQ(r.names, (std::vector<std::string>{"t", "x", "v", "E", "f"}));
  ASSERT_EQ(r.columns.size(), 5u);
  EXPECT_NEAR(r.columns[1].front(), 1.0, 1e-6);  // x <- Disp
  EXPECT_NEAR(Mean(r.columns[1]), 1.0, 0.01);    //
  EXPECT_NEAR(Mean(r.columns[2]), 20.0, 0.1);    // v <- Vel
  EXPECT_NEAR(Mean(r.columns[3]), 1.5, 0.01);    // E <- Volt
  EXPECT_NEAR(Mean(r.columns[4]), 600.0, 1.0);   // f <- Force x 2
  EXPECT_EQ(r.columns[0].size(), 2000u);         // t <- time (any other is not increasing)
}

}  // namespace
}  // namespace mrd::host
