#pragma once
// PNG plots through gnuplot (Debian package gnuplot-nox). Host only.

#include <string>
#include <vector>

namespace mrd::host {

struct PlotSeries {
  std::string title;
  std::vector<double> x, y;     // same length; a non-finite point (or y <= 0 on a log y axis)
                                // is left out and breaks the line there (a gap)
  std::string style = "lines";  // gnuplot style: lines, points, linespoints, with options
                                // (e.g. "points pointtype 7 pointsize 1.5")
};

// A dashed vertical line across the plot at x, labelled at the top.
struct PlotMarker {
  double x = 0.0;
  std::string label;
};

struct PlotSpec {
  std::string title, xlabel, ylabel;
  std::vector<PlotSeries> series;
  bool log_y = false;
  int width = 900, height = 600;           // [px]; ignored for a panel of a PlotFigure
  std::vector<PlotMarker> x_markers = {};  // vertical lines, e.g. a selected iteration
};

// Several plots (panels) in one PNG on a grid, filled row by row.
struct PlotFigure {
  std::string title;             // above all panels ("" for none)
  std::vector<PlotSpec> panels;  // at most rows * columns
  int rows = 1, columns = 1;
  int width = 1200, height = 800;  // [px]
};

// Writes the plot to png_path (atomically: nothing is left behind on failure). Throws
// std::runtime_error when gnuplot is missing or fails (its message included),
// std::invalid_argument for series of different x/y lengths or too many panels. A plot
// (panel) without any valid point is drawn empty with the note "no finite values".
void PlotPng(const PlotSpec& spec, const std::string& png_path);
void PlotPng(const PlotFigure& figure, const std::string& png_path);

// True when a `gnuplot` executable is on PATH (checked without running it).
bool GnuplotAvailable();

}  // namespace mrd::host
