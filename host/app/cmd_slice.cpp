// mrd slice: a time segment of a data file, for identification/validation splits and k-fold
// cross-validation on one measured run.
#include <fmt/format.h>

#include <memory>
#include <string>

#include "commands.hpp"
#include "mrd/common/cli_checks.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::host::cli {
namespace {

struct SliceOptions {
  std::string in, out;
  double from = 0.0, to = 0.0;  // [s], within the file's time range
};

void RunSlice(const SliceOptions& o) {
  CheckOutputPath(o.out);
  const DataSet ds = ReadCsv(o.in);
  const std::vector<double>& t = ds.Column("t");
  if (!(o.from < o.to)) {
    throw InputError("", 0, fmt::format("--from ({}) must be less than --to ({})", o.from, o.to));
  }
  // Rows with from <= t < to (half open, so adjacent slices share no row); a half-sample
  // tolerance absorbs printing error in t.
  const double eps = 0.5 * ds.dt;
  std::size_t first = 0, last = 0;
  while (first < t.size() && t[first] < o.from - eps) ++first;
  last = first;
  while (last < t.size() && t[last] < o.to - eps) ++last;
  if (last - first < 2) {
    throw InputError(
        o.in, 0,
        fmt::format("slice {} ... {} s holds fewer than 2 rows (file spans {} ... {} s)", o.from,
                    o.to, t.front(), t.back()));
  }
  std::vector<std::vector<double>> cols;
  for (const auto& c : ds.columns) {
    cols.emplace_back(c.begin() + static_cast<std::ptrdiff_t>(first),
                      c.begin() + static_cast<std::ptrdiff_t>(last));
  }
  WriteCsv(o.out, ds.names, cols);
  fmt::print("{}: rows {} ... {} of {} (t {:.4f} ... {:.4f} s)\n", o.out, first, last - 1,
             ds.rows(), t[first], t[last - 1]);
}

}  // namespace

void RegisterSlice(CLI::App& app) {
  auto o = std::make_shared<SliceOptions>();
  CLI::App* cmd = app.add_subcommand(
      "slice",
      "Cut the rows with FROM <= t < TO out of a data file (hold-out validation, "
      "k-fold segments).");
  cmd->add_option("--in", o->in, "Input data file (CSV with column t)")->required();
  cmd->add_option("--from", o->from, "Start time [s] (inclusive)")
      ->required()
      ->check(mrd::cli::Finite);
  cmd->add_option("--to", o->to, "End time [s] (exclusive)")->required()->check(mrd::cli::Finite);
  cmd->add_option("--out", o->out, "Output CSV file")->required();
  cmd->callback([o] { RunSlice(*o); });
}

}  // namespace mrd::host::cli
