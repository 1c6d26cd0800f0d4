#include "mrd/host/plot.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

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
int RunGnuplot(const std::string& script, const std::string& log, std::string* err) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  std::string prog = "gnuplot";
  char* argv[] = {prog.data(), const_cast<char*>(script.c_str()), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    *err = "cannot run gnuplot (install the Debian package gnuplot-nox)";
    return -1;
  }
  int status = 0;
  waitpid(pid, &status, 0);
  std::ifstream in(log);
  err->assign(std::istreambuf_iterator<char>(in), {});
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

void PlotPng(const PlotSpec& spec, const std::string& png_path) {
  namespace fs = std::filesystem;
  char tmpl[] = "/tmp/mrd-plot-XXXXXX";
  if (mkdtemp(tmpl) == nullptr) throw std::runtime_error("cannot create a temporary directory");
  const fs::path dir = tmpl;
  struct Cleanup {
    fs::path dir;
    ~Cleanup() { std::error_code ec; fs::remove_all(dir, ec); }
  } cleanup{dir};

  fmt::memory_buffer script;
  auto out = std::back_inserter(script);
  const fs::path tmp_png = dir / "plot.png";
  fmt::format_to(out, "set terminal pngcairo size {},{} noenhanced\n", spec.width, spec.height);
  fmt::format_to(out, "set output {}\n", Quote(tmp_png.string()));
  fmt::format_to(out, "set title {}\nset xlabel {}\nset ylabel {}\nset grid\nset key outside below\n",
                 Quote(spec.title), Quote(spec.xlabel), Quote(spec.ylabel));
  if (spec.log_y) fmt::format_to(out, "set logscale y\n");
  fmt::format_to(out, "plot ");
  for (std::size_t i = 0; i < spec.series.size(); ++i) {
    const PlotSeries& s = spec.series[i];
    if (s.x.size() != s.y.size()) throw std::invalid_argument("plot series lengths differ");
    const fs::path data = dir / fmt::format("s{}.dat", i);
    fmt::memory_buffer d;
    for (std::size_t k = 0; k < s.x.size(); ++k) {
      fmt::format_to(std::back_inserter(d), "{:.9g} {:.9g}\n", s.x[k], s.y[k]);
    }
    std::ofstream(data) << fmt::to_string(d);
    fmt::format_to(out, "{}{} using 1:2 with {} title {}", i == 0 ? "" : ", ",
                   Quote(data.string()), s.style, Quote(s.title));
  }
  fmt::format_to(out, "\n");
  const fs::path script_path = dir / "plot.gp";
  std::ofstream(script_path) << fmt::to_string(script);

  std::string err;
  const int status = RunGnuplot(script_path.string(), (dir / "gnuplot.log").string(), &err);
  if (status != 0 || !fs::exists(tmp_png)) {
    throw std::runtime_error(fmt::format("gnuplot failed for {}: {}", png_path, err));
  }
  std::error_code ec;
  fs::copy_file(tmp_png, png_path + ".tmp", fs::copy_options::overwrite_existing, ec);
  if (!ec) fs::rename(png_path + ".tmp", png_path, ec);
  if (ec) throw std::runtime_error(fmt::format("{}: {}", png_path, ec.message()));
}

}  // namespace mrd::host
