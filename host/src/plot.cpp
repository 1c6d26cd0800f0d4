#include "mrd/host/plot.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <string_view>

#include "mrd/common/find_program.hpp"
#include "mrd/common/gnuplot.hpp"
#include "mrd/host/atomic_write.hpp"

extern char** environ;

namespace mrd::host {
namespace {

// Quotes a string for a gnuplot double-quoted literal.
std::string Quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out.push_back('\\');
    out.push_back(c);
  }
  return out + "\"";
}

// Runs gnuplot on a script; returns its exit status and captured stderr.
// Appends one panel's settings and plot command to the script, its data files to dir.
void WritePanel(const PlotSpec& spec, const std::filesystem::path& dir, std::size_t panel,
                fmt::memory_buffer& script) {
  auto out = std::back_inserter(script);
  fmt::format_to(out, "unset logscale\nunset arrow\nunset label\nset autoscale\n");
  fmt::format_to(out, "set title {}\nset xlabel {}\nset ylabel {}\nset grid\n", Quote(spec.title),
                 Quote(spec.xlabel), Quote(spec.ylabel));
  fmt::format_to(out, "set key outside below\n");
  if (spec.log_y) fmt::format_to(out, "set logscale y\n");
  for (const PlotMarker& m : spec.x_markers) {
    fmt::format_to(out,
                   "set arrow from first {0:.9g}, graph 0 to first {0:.9g}, graph 1 nohead "
                   "dashtype 2 linecolor rgb \"gray30\"\n",
                   m.x);
    fmt::format_to(out, "set label {} at first {:.9g}, graph 0.96 left offset 0.5,0\n",
                   Quote(m.label), m.x);
  }
  std::vector<std::string> items;
  bool any_valid = false;
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& s = spec.series[i];
    if (s.x.size() != s.y.size()) throw std::invalid_argument("plot series lengths differ");
    fmt::memory_buffer d;
    std::size_t valid = 0;
    bool gap = false;
    for (std::size_t k = 0; k < s.x.size(); ++k) {
      const bool ok =
          std::isfinite(s.x[k]) && std::isfinite(s.y[k]) && (!spec.log_y || s.y[k] > 0.0);
      if (!ok) {
        gap = true;
        continue;
      }
      if (gap && valid > 0) fmt::format_to(std::back_inserter(d), "\n");
      gap = false;
      ++valid;
      fmt::format_to(std::back_inserter(d), "{:.9g} {:.9g}\n", s.x[k], s.y[k]);
    }
    if (valid == 0) {  // gnuplot refuses a file without valid points: keep the key entry
      items.push_back(fmt::format("keyentry with {} title {}", s.style, Quote(s.title)));
      continue;
    }
    any_valid = true;
    const std::filesystem::path data = dir / fmt::format("p{}s{}.dat", panel, i);
    std::ofstream(data) << fmt::to_string(d);
    items.push_back(fmt::format("{} using 1:2 with {} title {}", Quote(data.string()), s.style,
                                Quote(s.title)));
  }
  if (!any_valid) {
    fmt::format_to(out, "set xrange [0:1]\nset yrange [{}]\n", spec.log_y ? "1:10" : "0:1");
    fmt::format_to(out, "set label \"no finite values\" at graph 0.5, graph 0.5 center\n");
    items.insert(items.begin(), "NaN notitle");
  }
  fmt::format_to(out, "plot {}\n", fmt::join(items, ", "));
}

}  // namespace

void PlotPng(const PlotSpec& spec, const std::string& png_path) {
  PlotFigure figure;
  figure.panels = {spec};
  figure.width = spec.width;
  figure.height = spec.height;
  PlotPng(figure, png_path);
}

void PlotPng(const PlotFigure& figure, const std::string& png_path) {
  namespace fs = std::filesystem;
  if (figure.rows < 1 || figure.columns < 1 ||
      figure.panels.size() > static_cast<std::size_t>(figure.rows * figure.columns)) {
    throw std::invalid_argument("more plot panels than the figure's grid holds");
  }
  const char* tmp_root = std::getenv("TMPDIR");
  const TempDir work(tmp_root != nullptr && *tmp_root != '\0' ? tmp_root : "/tmp", "mrd-plot");
  const fs::path dir = work.path();

  fmt::memory_buffer script;
  auto out = std::back_inserter(script);
  const fs::path tmp_png = dir / "plot.png";
  fmt::format_to(out, "set terminal pngcairo size {},{} noenhanced\n", figure.width, figure.height);
  fmt::format_to(out, "set output {}\n", Quote(tmp_png.string()));
  const bool multi = figure.panels.size() > 1 || !figure.title.empty();
  if (multi) {
    fmt::format_to(out, "set multiplot layout {},{} rowsfirst title {}\n", figure.rows,
                   figure.columns, Quote(figure.title));
  }
  for (std::size_t p = 0; p < figure.panels.size(); ++p) {
    WritePanel(figure.panels[p], dir, p, script);
  }
  if (multi) fmt::format_to(out, "unset multiplot\n");
  const fs::path script_path = dir / "plot.gp";
  std::ofstream(script_path) << fmt::to_string(script);

  std::string err;
  const int status = common::RunGnuplot(script_path.string(), (dir / "gnuplot.log").string(), &err);
  if (status != 0 || !fs::exists(tmp_png) || fs::file_size(tmp_png) == 0) {
    throw std::runtime_error(fmt::format("gnuplot failed for {}: {}", png_path, err));
  }
  std::ifstream png(tmp_png, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(png)), std::istreambuf_iterator<char>());
  WriteFileAtomic(png_path, bytes);
}

bool GnuplotAvailable() { return !common::FindProgram("gnuplot").empty(); }

}  // namespace mrd::host
