// The firmware's per-period log (common/runlog, docs/logging.md), read as `mrd log` reads it
// (host/run_log.hpp): every field as a numpy array of its own type, and what `mrd log info`
// says about the file.
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "mrd/host/run_log.hpp"

namespace mrd::python {
namespace {

PyObject* g_log_warning = nullptr;  // mrd.LogWarning (a new reference, kept)

template <class T>
py::array Column(const runlog::Log& log, const std::vector<std::uint32_t>& off, std::size_t i) {
  py::array_t<T> a(static_cast<py::ssize_t>(log.num_records));
  T* out = a.mutable_data();
  for (std::uint64_t r = 0; r < log.num_records; ++r) {
    const std::uint64_t bits = runlog::Bits(log, off, r, i);
    if constexpr (sizeof(T) == sizeof(bits)) {
      std::memcpy(&out[r], &bits, sizeof bits);  // i64 two's complement, f64 IEEE bits
    } else {
      out[r] = static_cast<T>(bits);
    }
  }
  return a;
}

py::array FieldArray(const runlog::Log& log, const std::vector<std::uint32_t>& off, std::size_t i) {
  switch (log.header.fields[i].type) {
    case runlog::Type::kU8:
      return Column<std::uint8_t>(log, off, i);
    case runlog::Type::kU32:
      return Column<std::uint32_t>(log, off, i);
    case runlog::Type::kU64:
      return Column<std::uint64_t>(log, off, i);
    case runlog::Type::kI64:
      return Column<std::int64_t>(log, off, i);
    case runlog::Type::kF64:
      return Column<double>(log, off, i);
  }
  throw BadInput("unknown field type");  // DecodeLog refuses unknown types
}

// LoadRunLog with the CLI's words; a truncated tail is a warning (the CLI's note).
runlog::Log Load(const std::string& path, bool allow_corrupt) {
  runlog::Log log = Checked({path}, [&] { return host::LoadRunLog(path, allow_corrupt); });
  if (log.damage == runlog::Damage::kTruncated) {
    Warn(g_log_warning, host::RunLogDamageNote(log, path));
  }
  return log;
}

py::dict ReadLog(const py::object& file, const std::optional<std::vector<std::string>>& fields) {
  const std::string path = PathOf(file);
  const runlog::Log log = Load(path, false);
  const std::vector<std::size_t> cols = Checked({}, [&] {
    return host::RunLogColumns(log.header, fields.value_or(std::vector<std::string>{}));
  });
  const std::vector<std::uint32_t> off = log.header.Offsets();
  py::dict out;
  for (const std::size_t i : cols)
    out[py::str(log.header.fields[i].name)] = FieldArray(log, off, i);
  return out;
}

const char* DamageName(runlog::Damage d) {
  switch (d) {
    case runlog::Damage::kNone:
      return "none";
    case runlog::Damage::kTruncated:
      return "truncated";
    case runlog::Damage::kCorrupt:
      return "corrupt";
  }
  return "?";
}

py::dict LogInfo(const py::object& file) {
  const std::string path = PathOf(file);
  const runlog::Log log = Load(path, true);
  py::dict d;
  d["version"] = log.header.version;
  d["source"] = log.header.source;
  d["period_ns"] = log.header.period_ns;
  d["file_index"] = log.header.file_index;
  py::list fields;
  for (const runlog::Field& f : log.header.fields) {
    py::dict fd;
    fd["name"] = f.name;
    fd["type"] = runlog::TypeName(f.type);
    fd["unit"] = f.unit;
    fields.append(fd);
  }
  d["fields"] = fields;
  d["records"] = log.num_records;
  d["blocks"] = log.blocks;
  d["first_sequence"] = log.first_sequence;
  d["last_sequence"] = log.last_sequence;
  d["sequence_gaps"] = log.sequence_gaps;
  d["dropped"] = log.dropped;
  d["file_bytes"] = log.file_bytes;
  d["valid_bytes"] = log.valid_bytes;
  d["damage"] = DamageName(log.damage);
  d["damage_note"] = host::RunLogDamageNote(log, path);
  d["text"] = host::RunLogInfo(log, path);
  return d;
}

}  // namespace

void RegisterLogs(py::module_& m) {
  g_log_warning = PyErr_NewExceptionWithDoc(
      "mrd.LogWarning",
      "A per-period log cut inside its last block (read up to its last whole block, as `mrd "
      "log` notes on stderr).",
      PyExc_UserWarning, nullptr);
  m.attr("LogWarning") = py::handle(g_log_warning);
  m.def("_read_log", &ReadLog, py::arg("path"), py::arg("fields") = py::none());
  m.def("log_info", &LogInfo, py::arg("path"),
        "What `mrd log info` says about a log: version, source, period, fields (name, type, "
        "unit), records, blocks, dropped, damage; 'text' is the CLI's text. A corrupt block is "
        "reported (damage 'corrupt'), not raised");
}

}  // namespace mrd::python
