#include "mrd/host/plot.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>

#include "test_util.hpp"

namespace mrd::host {
namespace {

TEST(PlotTest, WritesPng) {
  test::TempDir dir;
  PlotSpec spec{"t \"quoted\"", "x", "y", {{"a", {0, 1, 2}, {1, 4, 9}, "lines"}}};
  const auto png = dir.File("p.png");
  PlotPng(spec, png);
  std::ifstream in(png, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
}

TEST(PlotTest, MismatchedSeriesThrowsAndWritesNothing) {
  test::TempDir dir;
  PlotSpec spec{"t", "x", "y", {{"a", {0, 1}, {1}, "lines"}}};
  EXPECT_THROW(PlotPng(spec, dir.File("p.png")), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.File("p.png")));
}

bool IsPngFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return std::string(magic, 8) == "\x89PNG\r\n\x1a\n";
}

TEST(PlotTest, FigureWithPanelsMarkersAndGapsWritesPng) {
  test::TempDir dir;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  PlotSpec a{"a", "x", "y", {{"gap", {1, 2, 3, 4}, {1, nan, 3, 4}, "linespoints"}}, true};
  a.x_markers.push_back({2.5, "selected"});
  PlotSpec b{"b", "x", "y", {{"plain", {0, 1}, {0, -1}, "lines"}}};
  PlotFigure f{"two panels", {a, b}, 2, 1};
  PlotPng(f, dir.File("f.png"));
  EXPECT_TRUE(IsPngFile(dir.File("f.png")));
}

TEST(PlotTest, PanelWithoutValidPointsStillPlots) {
  test::TempDir dir;
  const double inf = std::numeric_limits<double>::infinity();
  PlotSpec spec{"empty", "x", "y", {{"all bad", {1, 2}, {inf, -1}, "lines"}}, true};
  PlotPng(spec, dir.File("e.png"));
  EXPECT_TRUE(IsPngFile(dir.File("e.png")));
}

TEST(PlotTest, MorePanelsThanGridThrowsAndWritesNothing) {
  test::TempDir dir;
  PlotSpec p{"p", "x", "y", {{"a", {0, 1}, {0, 1}, "lines"}}};
  PlotFigure f{"", {p, p}, 1, 1};
  EXPECT_THROW(PlotPng(f, dir.File("p.png")), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir.File("p.png")));
}

}  // namespace
}  // namespace mrd::host
