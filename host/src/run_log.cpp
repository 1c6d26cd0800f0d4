#include "mrd/host/run_log.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "mrd/common/fault_causes.hpp"
#include "mrd/host/input_error.hpp"
#include "mrd/host/plot.hpp"

namespace mrd::host {
namespace {

std::string FieldList(const runlog::Header& h) {
  std::string s;
  for (const auto& f : h.fields) s += (s.empty() ? "" : ", ") + f.name;
  return s;
}

std::uint64_t Raw(const runlog::Log& log, const std::vector<std::uint32_t>& off, std::uint64_t r,
                  std::size_t i) {
  return runlog::Bits(log, off, r, i);
}

std::string Text(const runlog::Log& log, const std::vector<std::uint32_t>& off, std::uint64_t r,
                 std::size_t i) {
  switch (log.header.fields[i].type) {
    case runlog::Type::kI64:
      return fmt::format("{}", static_cast<std::int64_t>(Raw(log, off, r, i)));
    case runlog::Type::kF64:
      return fmt::format("{}", runlog::Value(log, off, r, i));
    default:
      return fmt::format("{}", Raw(log, off, r, i));
  }
}

}  // namespace

runlog::Log LoadRunLog(const std::string& path, bool allow_corrupt) {
  runlog::Log log;
  std::string error;
  if (!runlog::ReadLog(path, &log, &error)) {
    // ReadLog's message starts with the path.
    throw InputError("", 0, error);
  }
  if (log.damage == runlog::Damage::kCorrupt && !allow_corrupt) {
    throw InputError("", 0, RunLogDamageNote(log, path));
  }
  return log;
}

std::string RunLogDamageNote(const runlog::Log& log, const std::string& path) {
  switch (log.damage) {
    case runlog::Damage::kNone:
      return "";
    case runlog::Damage::kTruncated:
      return fmt::format(
          "{}: truncated in block {} at byte {} ({}); read up to the last whole "
          "block ({} records, {} bytes of {})",
          path, log.damage_block, log.damage_offset, log.damage_reason, log.num_records,
          log.valid_bytes, log.file_bytes);
    case runlog::Damage::kCorrupt:
      return fmt::format(
          "{}: corrupt block {} at byte {} ({}); the {} records of the {} blocks "
          "before it are intact, nothing after it was read",
          path, log.damage_block, log.damage_offset, log.damage_reason, log.num_records,
          log.blocks);
  }
  return "";
}

std::string RunLogInfo(const runlog::Log& log, const std::string& path) {
  const runlog::Header& h = log.header;
  std::string s = fmt::format("{}\n  format:   mrd per-period log, version {}\n", path, h.version);
  s += fmt::format("  source:   {}\n", h.source.empty() ? "(none)" : h.source);
  s += fmt::format("  period:   {:g} us\n", static_cast<double>(h.period_ns) / 1e3);
  s += fmt::format("  file:     index {} (0: first; rotated files count up), {} bytes\n",
                   h.file_index, log.file_bytes);
  s += fmt::format("  records:  {} ({} bytes each)\n", log.num_records, h.record_bytes());
  s += fmt::format("  blocks:   {}", log.blocks);
  if (log.blocks > 0) {
    s += fmt::format(
        " (sequence {} to {}{})", log.first_sequence, log.last_sequence,
        log.sequence_gaps > 0 ? fmt::format(", {} missing", log.sequence_gaps) : std::string());
  }
  s += "\n";
  const int t = runlog::FieldIndex(h, "t_ns");
  const int period = runlog::FieldIndex(h, "period");
  if (log.num_records > 0 && t >= 0) {
    const auto off = h.Offsets();
    const double t0 = runlog::Value(log, off, 0, static_cast<std::size_t>(t));
    const double t1 = runlog::Value(log, off, log.num_records - 1, static_cast<std::size_t>(t));
    s += fmt::format("  time:     {:.9g} s to {:.9g} s ({:.9g} s)\n", t0 * 1e-9, t1 * 1e-9,
                     (t1 - t0) * 1e-9);
    if (period >= 0) {
      const auto p0 = Raw(log, off, 0, static_cast<std::size_t>(period));
      const auto p1 = Raw(log, off, log.num_records - 1, static_cast<std::size_t>(period));
      s += fmt::format("  periods:  {} to {} ({} periods, {} not in the file)\n", p0, p1,
                       p1 - p0 + 1, p1 - p0 + 1 - log.num_records);
    }
  }
  s += fmt::format("  dropped:  {} (ring full, counted by the writer up to the last block)\n",
                   log.dropped);
  s += fmt::format("  damage:   {}\n", log.damage == runlog::Damage::kNone
                                           ? std::string("none")
                                           : RunLogDamageNote(log, path));
  s += "  fields:\n";
  for (const auto& f : h.fields) {
    s += fmt::format("    {:<16} {:<4} {}\n", f.name, runlog::TypeName(f.type),
                     f.unit.empty() ? "-" : f.unit);
  }
  return s;
}

std::vector<std::size_t> RunLogColumns(const runlog::Header& header,
                                       const std::vector<std::string>& fields) {
  std::vector<std::size_t> cols;
  if (fields.empty()) {
    for (std::size_t i = 0; i < header.fields.size(); ++i) cols.push_back(i);
  }
  for (const std::string& name : fields) {
    const int i = runlog::FieldIndex(header, name);
    if (i < 0) {
      throw InputError(
          "", 0,
          fmt::format("--fields: unknown field '{}'; the log has: {}", name, FieldList(header)));
    }
    // A repeated column would make a CSV that ReadCsv refuses (duplicate column).
    if (std::find(cols.begin(), cols.end(), static_cast<std::size_t>(i)) != cols.end()) {
      throw InputError("", 0, fmt::format("--fields: field '{}' given twice", name));
    }
    cols.push_back(static_cast<std::size_t>(i));
  }
  return cols;
}

std::string RunLogCsv(const runlog::Log& log, const std::vector<std::string>& fields) {
  const std::vector<std::size_t> cols = RunLogColumns(log.header, fields);
  const auto off = log.header.Offsets();
  std::string out;
  out.reserve(static_cast<std::size_t>(log.num_records) * cols.size() * 12 + 256);
  for (std::size_t c = 0; c < cols.size(); ++c) {
    out += (c == 0 ? "" : ",") + log.header.fields[cols[c]].name;
  }
  out += "\n";
  for (std::uint64_t r = 0; r < log.num_records; ++r) {
    for (std::size_t c = 0; c < cols.size(); ++c) {
      if (c > 0) out += ',';
      out += Text(log, off, r, cols[c]);
    }
    out += '\n';
  }
  return out;
}

std::string PlotRunLog(const runlog::Log& log, const std::string& path, const std::string& out_dir,
                       const TimeWindow* window,
                       const std::function<void(const std::string&)>& progress) {
  namespace fs = std::filesystem;
  const runlog::Header& h = log.header;
  const auto need = [&](const char* name) {
    const int i = runlog::FieldIndex(h, name);
    if (i < 0) throw InputError("", 0, fmt::format("{}: the log has no field '{}'", path, name));
    return static_cast<std::size_t>(i);
  };
  const std::size_t t_i = need("t_ns"), safe_i = need("safe"), causes_i = need("causes");
  const std::size_t model_i = need("model_force"), demand_i = need("force_demand");
  const std::size_t force_i = need("force"), command_i = need("command"), e_i = need("e_law");
  const fs::path dir(out_dir);
  if (fs::exists(dir) && !fs::is_directory(dir)) {
    throw InputError("", 0, fmt::format("--out {}: not a directory", out_dir));
  }
  if (!fs::exists(dir)) {
    const fs::path parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
    if (!fs::is_directory(parent)) {
      throw InputError("", 0,
                       fmt::format("--out {}: its parent directory does not exist", out_dir));
    }
    fs::create_directory(dir);
  }
  // Every record (the window is drawn sample by sample, the overview as an envelope).
  const std::uint64_t n = log.num_records;
  const auto off = h.Offsets();
  const double t0 = n > 0 ? runlog::Value(log, off, 0, t_i) : 0.0;
  std::vector<double> all_t, all_model, all_demand, all_force, all_command, all_e, all_safe;
  std::vector<std::uint32_t> all_causes;
  for (std::uint64_t r = 0; r < n; ++r) {
    all_t.push_back((runlog::Value(log, off, r, t_i) - t0) * 1e-9);
    all_model.push_back(runlog::Value(log, off, r, model_i));
    all_demand.push_back(runlog::Value(log, off, r, demand_i));
    all_force.push_back(runlog::Value(log, off, r, force_i));
    all_command.push_back(runlog::Value(log, off, r, command_i));
    all_e.push_back(runlog::Value(log, off, r, e_i));
    all_safe.push_back(runlog::Value(log, off, r, safe_i) != 0.0 ? 1.0 : 0.0);
    all_causes.push_back(static_cast<std::uint32_t>(Raw(log, off, r, causes_i)));
  }
  std::string note;
  const TimeWindow w = PlotWindow(all_t, window, &note);
  if (!note.empty() && progress) progress("log: " + note);
  const SampleRange in = SamplesIn(all_t, w);
  const std::vector<double> t = Slice(all_t, in), model = Slice(all_model, in),
                            demand = Slice(all_demand, in), force = Slice(all_force, in),
                            command = Slice(all_command, in), e_law = Slice(all_e, in),
                            safe = Slice(all_safe, in);
  const std::vector<std::uint32_t> causes(
      all_causes.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(in.first, n)),
      all_causes.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(in.last, n)));
  // The safe state as a band over the panel's data range.
  const auto shade = [&](const std::vector<const std::vector<double>*>& data) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto* d : data) {
      for (const double v : *d) {
        if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
      }
    }
    if (!std::isfinite(lo)) lo = 0.0, hi = 1.0;
    PlotSeries band{"safe state", t, std::vector<double>(t.size()),
                    fmt::format("filledcurves y1={:.9g} fs transparent solid 0.2 noborder "
                                "linecolor rgb \"#d62728\"",
                                lo)};
    for (std::size_t k = 0; k < t.size(); ++k) {
      band.y[k] = safe[k] != 0.0 ? hi : std::numeric_limits<double>::quiet_NaN();
    }
    return band;
  };
  PlotSpec forces{"Force", "t [s]", "force [N]", {}};
  forces.series = {shade({&model, &demand, &force}),
                   {"model force", t, model},
                   {"demand", t, demand},
                   {"measured force", t, force}};
  PlotSpec volts{"Command", "t [s]", "E [V]", {}};
  volts.series = {shade({&command, &e_law}),
                  {"command written", t, command},
                  {"law's E (before clamping; none when safe)", t, e_law}};
  PlotSpec state{"State", "t [s]", "", {}};
  state.series = {shade({&safe}), {"safe (1)", t, safe, "steps"}};
  std::uint32_t seen = 0;
  for (const std::uint32_t c : causes) seen |= c;
  for (std::size_t b = 0; b < 32; ++b) {
    if ((seen & (1U << b)) == 0) continue;
    PlotSeries s{
        b < std::size(kFaultCauseNames) ? kFaultCauseNames[b] : fmt::format("cause bit {}", b), t,
        std::vector<double>(t.size()), "steps"};
    for (std::size_t k = 0; k < t.size(); ++k) {
      s.y[k] = (causes[k] & (1U << b)) != 0 ? 1.0 : std::numeric_limits<double>::quiet_NaN();
    }
    state.series.push_back(std::move(s));
  }
  // The whole log: envelopes of the forces (2000 buckets), the window marked.
  PlotSpec overview{
      fmt::format("Overview: the whole log, envelope per {:.3g} s (window {:g} .. "
                  "{:g} s above)",
                  all_t.empty() ? 0.0 : (all_t.back() - all_t.front()) / 2000.0, w.from_s, w.to_s),
      "t [s]",
      "force [N]",
      {}};
  for (const auto& [title, y] :
       {std::pair<const char*, const std::vector<double>*>{"measured force", &all_force},
        {"demand", &all_demand},
        {"model force", &all_model}}) {
    PlotSeries s{title, {}, {}};
    Envelope(all_t, *y, 2000, &s.x, &s.y);
    overview.series.push_back(std::move(s));
  }
  overview.x_markers = {{w.from_s, "window"}, {w.to_s, ""}};
  forces.title = fmt::format("Force, {:g} .. {:g} s (--window FROM:TO)", w.from_s, w.to_s);
  PlotFigure fig;
  fig.title = fmt::format("{} ({} records, period {:g} us)", fs::path(path).filename().string(), n,
                          static_cast<double>(h.period_ns) / 1e3);
  fig.panels = {forces, volts, state, overview};
  fig.rows = 4;
  fig.width = 1200;
  fig.height = 1400;
  const std::string png = (dir / (fs::path(path).stem().string() + "_time.png")).string();
  if (progress) progress(fmt::format("log: plotting {} ({} points per series)", png, t.size()));
  PlotPng(fig, png);
  return png;
}

}  // namespace mrd::host
