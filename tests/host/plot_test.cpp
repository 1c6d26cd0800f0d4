#include "mrd/host/plot.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

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

}  // namespace
}  // namespace mrd::host
