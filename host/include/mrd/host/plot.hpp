#pragma once
// PNG plots through gnuplot (Debian package gnuplot-nox). Host only.

#include <string>
#include <vector>

namespace mrd::host {

struct PlotSeries {
  std::string title;
  std::vector<double> x, y;  // same length
  std::string style = "lines";  // gnuplot style: lines, points, linespoints
};

struct PlotSpec {
  std::string title, xlabel, ylabel;
  std::vector<PlotSeries> series;
  bool log_y = false;
  int width = 900, height = 600;  // [px]
};

// Writes the plot to png_path (atomically: nothing is left behind on failure). Throws
// std::runtime_error when gnuplot is missing or fails (its message included).
void PlotPng(const PlotSpec& spec, const std::string& png_path);

}  // namespace mrd::host
