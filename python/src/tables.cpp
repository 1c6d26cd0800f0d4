// Coefficient tables (common/table.hpp): read and check as the firmware does (its table file
// loader and `mrd-firmware --check-table`), encode, and run the firmware's model runtime and
// analytic inverter (firmware/model_runtime.hpp, inverter.hpp) on arrays.
#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "mrd/common/input_file.hpp"
#include "mrd/common/model_check.hpp"
#include "mrd/firmware/inverter.hpp"
#include "mrd/firmware/model_runtime.hpp"
#include "mrd/firmware/platform/config.hpp"
#include "mrd/firmware/platform/table_file.hpp"
#include "mrd/firmware/platform/table_update.hpp"
#include "mrd/host/table_export.hpp"

namespace mrd::python {
namespace {

struct Table {
  CoefficientTable table;
  std::string source;  // file or model it came from, for messages
};

// The firmware's settings the runtime and the inverter take (ControllerConfig's defaults, or
// a firmware config file's).
struct RunSettings {
  double e_max = 0.0;  // [V]
  bool envelope = true;
  double margin = 0.1;
};

// OSError when path cannot be opened as a regular file, else ValueError, with the text.
[[noreturn]] void Refuse(const std::string& text, const std::string& path) {
  Rethrow(host::InputError("", 0, text), {path});
}

firmware::platform::FirmwareConfig LoadConfig(const std::string& path) {
  firmware::platform::FirmwareConfig config;
  std::string error;
  if (!firmware::platform::LoadConfigFile(path, &config, &error)) Refuse(error, path);
  return config;
}

RunSettings SettingsOf(const Table& t, const std::optional<std::string>& config,
                       std::optional<double> e_max, std::optional<bool> envelope,
                       std::optional<double> margin) {
  RunSettings s;
  firmware::ControllerConfig c;
  std::optional<double> config_e_max;
  if (config) {
    const firmware::platform::FirmwareConfig fc = LoadConfig(*config);
    c = fc.controller;
    config_e_max = fc.e_max;
  }
  s.e_max = e_max.value_or(config_e_max.value_or(t.table.e_max));
  s.envelope = envelope.value_or(c.envelope);
  s.margin = margin.value_or(c.envelope_margin);
  return s;
}

// The runtime bound to the table, as the firmware's Controller::Configure binds it.
void Configure(const Table& t, const RunSettings& s, firmware::ModelRuntime* runtime,
               firmware::Inverter* inverter) {
  const auto refuse = [&](const char* what, Error e) {
    throw BadInput(
        fmt::format("table {} refused by the firmware's {}: {}", t.source, what, ErrorName(e)));
  };
  if (const Error e = runtime->Configure(t.table); e != Error::kOk) refuse("model runtime", e);
  if (inverter != nullptr) {
    if (const Error e = inverter->Configure(t.table); e != Error::kOk) refuse("inverter", e);
    if (const Error e = inverter->SetRange(t.table.e_min, s.e_max); e != Error::kOk) {
      throw BadInput(fmt::format("e_max {} V is outside the table's range [{}, {}] V", s.e_max,
                                 t.table.e_min, t.table.e_max));
    }
  }
  if (const Error e = runtime->SetEnvelope(s.envelope, s.margin); e != Error::kOk) {
    throw BadInput(fmt::format("envelope_margin {}: must be finite and >= 0", s.margin));
  }
}

// Equal-length input arrays.
std::vector<std::vector<double>> Inputs(
    std::initializer_list<std::pair<const char*, py::handle>> in) {
  std::vector<std::vector<double>> out;
  for (const auto& [name, obj] : in) {
    out.push_back(ToDoubles(obj, name));
    for (std::size_t r = 0; r < out.back().size(); ++r) {
      if (!std::isfinite(out.back()[r])) {
        throw BadInput(fmt::format("{}: row {}: non-finite value '{}'", name, r, out.back()[r]));
      }
    }
    if (out.back().size() != out.front().size()) {
      throw BadInput(fmt::format("{} has {} values, {} has {}", name, out.back().size(),
                                 in.begin()->first, out.front().size()));
    }
  }
  return out;
}

// Model force [N] for the commands E [V] (the firmware's model runtime from a cleared history).
py::array_t<double> Simulate(const Table& t, const py::handle& v, const py::handle& x,
                             const py::handle& E, std::optional<bool> envelope,
                             std::optional<double> margin,
                             const std::optional<std::string>& config) {
  const RunSettings s = SettingsOf(t, config, std::nullopt, envelope, margin);
  const auto in = Inputs({{"v", v}, {"x", x}, {"E", E}});
  firmware::ModelRuntime runtime;
  Configure(t, s, &runtime, nullptr);
  std::vector<double> force(in[0].size());
  {
    const py::gil_scoped_release release;
    for (std::size_t k = 0; k < force.size(); ++k) {
      const auto f =
          runtime.Step(static_cast<firmware::Real>(in[0][k]), static_cast<firmware::Real>(in[1][k]),
                       static_cast<firmware::Real>(in[2][k]));
      force[k] = static_cast<double>(f);
      if (!std::isfinite(f)) runtime.Reset();  // as the firmware resets a diverged model
    }
  }
  return ToArray(std::move(force));
}

// The firmware's force-law period without its watchdog: per sample the model begins with v, x,
// the inverter solves for the demand at v (its sign the dissipative direction), the model
// finishes with the command. Where `command` is finite, that command is sent instead (e.g. the safe
// voltage of periods the firmware spent in the safe state) and nothing is inverted.
py::dict Invert(const Table& t, const py::handle& v, const py::handle& x, const py::handle& demand,
                const py::object& command, std::optional<double> e_max,
                std::optional<bool> envelope, std::optional<double> margin,
                const std::optional<std::string>& config) {
  const RunSettings s = SettingsOf(t, config, e_max, envelope, margin);
  const auto in = Inputs({{"v", v}, {"x", x}, {"demand", demand}});
  const std::size_t n = in[0].size();
  std::vector<double> fixed;
  if (!command.is_none()) {
    fixed = ToDoubles(command, "command");
    if (fixed.size() != n) {
      throw BadInput(fmt::format("command has {} values, v has {}", fixed.size(), n));
    }
    for (std::size_t r = 0; r < n; ++r) {
      if (std::isfinite(fixed[r]) && (fixed[r] < t.table.e_min || fixed[r] > t.table.e_max)) {
        throw BadInput(fmt::format("command: row {}: {} V is outside the table's range [{}, {}] V",
                                   r, fixed[r], t.table.e_min, t.table.e_max));
      }
    }
  }
  firmware::ModelRuntime runtime;
  firmware::Inverter inverter;
  Configure(t, s, &runtime, &inverter);
  using firmware::Real;
  std::vector<double> E(n), force(n);
  auto reachable = py::array_t<bool>(static_cast<py::ssize_t>(n));
  bool* ok = reachable.mutable_data();
  {
    const py::gil_scoped_release release;
    for (std::size_t k = 0; k < n; ++k) {
      const Real velocity = static_cast<Real>(in[0][k]);
      runtime.Begin(velocity, static_cast<Real>(in[1][k]));
      Real volts = Real(0);
      ok[k] = true;
      if (!fixed.empty() && std::isfinite(fixed[k])) {
        volts = static_cast<Real>(fixed[k]);
      } else {
        const firmware::Inverter::Solution sol =
            inverter.Solve(runtime.history(), static_cast<Real>(in[2][k]), velocity);
        volts = sol.E;
        ok[k] = sol.reachable;
      }
      const Real f = runtime.Finish(volts);
      if (!std::isfinite(f)) runtime.Reset();  // as the firmware resets a diverged model
      E[k] = static_cast<double>(volts);
      force[k] = static_cast<double>(f);
    }
  }
  py::dict out;
  out["E"] = ToArray(std::move(E));
  out["force"] = ToArray(std::move(force));
  out["reachable"] = reachable;
  return out;
}

const char* ProblemName(InversionProblem p) {
  switch (p) {
    case InversionProblem::kNone:
      return "none";
    case InversionProblem::kTransform:
      return "transform";
    case InversionProblem::kDegree:
      return "degree";
    case InversionProblem::kAbsent:
      return "absent";
  }
  return "?";
}

py::list Channels(const Table& t) {
  py::list out;
  const Model& m = t.table.model;
  for (std::size_t c = 0; c < m.num_channels; ++c) {
    py::dict d;
    d["name"] = std::string(m.channel_names[c].data());
    d["offset"] = m.scales[c].offset;
    d["scale"] = m.scales[c].scale;
    d["min"] = t.table.has_envelope ? py::object(py::float_(t.table.envelope[c].min)) : py::none();
    d["max"] = t.table.has_envelope ? py::object(py::float_(t.table.envelope[c].max)) : py::none();
    out.append(d);
  }
  return out;
}

std::optional<std::string> OptionalPath(const py::object& obj) {
  if (obj.is_none()) return std::nullopt;
  return PathOf(obj);
}

}  // namespace

py::object TableObject(CoefficientTable table, std::string source) {
  return py::cast(Table{std::move(table), std::move(source)});
}

void RegisterTables(py::module_& m) {
  py::class_<Table>(m, "Table",
                    "A coefficient table (docs/table_format.md): one model, its inverted input "
                    "and command range, and its operating envelope")
      .def_readonly("source", &Table::source)
      .def_property_readonly(
          "input",
          [](const Table& t) {
            return std::string(t.table.model.channel_names[t.table.input_channel].data());
          })
      .def_property_readonly(
          "output",
          [](const Table& t) {
            return std::string(t.table.model.channel_names[t.table.model.output_channel].data());
          })
      .def_property_readonly("e_min", [](const Table& t) { return t.table.e_min; })
      .def_property_readonly("e_max", [](const Table& t) { return t.table.e_max; })
      .def_property_readonly("has_envelope", [](const Table& t) { return t.table.has_envelope; })
      .def_property_readonly("channels", &Channels,
                             "Per channel: name, offset, scale, envelope min and max (None "
                             "without an envelope)")
      .def_property_readonly("num_terms", [](const Table& t) { return t.table.model.num_terms; })
      .def_property_readonly(
          "coefficients",
          [](const Table& t) {
            const Model& md = t.table.model;
            return ToArray(std::vector<double>(md.coefficients.begin(),
                                               md.coefficients.begin() + md.num_terms));
          },
          "Term coefficients (normalised units)")
      .def(
          "inversion",
          [](const Table& t) {
            const InversionCheck c = CheckInversion(t.table);
            py::dict d;
            d["invertible"] = c.problem == InversionProblem::kNone;
            d["problem"] = ProblemName(c.problem);
            d["term"] = c.term;
            d["degree"] = c.degree;
            return d;
          },
          "Whether the firmware can invert the table for its input (the check of the inverter "
          "and mrd export): problem none | transform | degree | absent, the term and degree")
      .def("to_bytes",
           [](const Table& t) {
             const TableBytes b = Checked({}, [&] { return host::TableImage(t.table); });
             return py::bytes(reinterpret_cast<const char*>(b.data()), b.size());
           })
      .def(
          "save",
          [](const Table& t, const py::object& path) {
            const TableBytes b = Checked({}, [&] { return host::TableImage(t.table); });
            SaveText(PathOf(path), std::string(reinterpret_cast<const char*>(b.data()), b.size()));
          },
          py::arg("path"), "Writes the binary image (atomically, as mrd export --table does)")
      .def(
          "simulate",
          [](const Table& t, const py::handle& v, const py::handle& x, const py::handle& E,
             std::optional<bool> envelope, std::optional<double> margin, const py::object& config) {
            return Simulate(t, v, x, E, envelope, margin, OptionalPath(config));
          },
          py::arg("v"), py::arg("x"), py::arg("E"), py::kw_only(), py::arg("envelope") = py::none(),
          py::arg("envelope_margin") = py::none(), py::arg("config") = py::none(),
          "Model force [N] for v [cm/s], x [cm] and the commands E [V], by the firmware's "
          "model runtime from a cleared history (inputs held to the envelope as the firmware "
          "holds them; defaults: the firmware's, or a firmware config file's)")
      .def(
          "invert",
          [](const Table& t, const py::handle& v, const py::handle& x, const py::handle& demand,
             const py::object& command, std::optional<double> e_max, std::optional<bool> envelope,
             std::optional<double> margin, const py::object& config) {
            return Invert(t, v, x, demand, command, e_max, envelope, margin, OptionalPath(config));
          },
          py::arg("v"), py::arg("x"), py::arg("demand"), py::kw_only(),
          py::arg("command") = py::none(), py::arg("e_max") = py::none(),
          py::arg("envelope") = py::none(), py::arg("envelope_margin") = py::none(),
          py::arg("config") = py::none(),
          "The firmware's analytic inversion on arrays: per sample, the command E [V] whose "
          "model force is the demand [N] at v (E_min for 0 N or a demand against v; the "
          "lowest E of the nearest force when unreachable), the model advancing with it. Returns "
          "E, force and reachable. "
          "command: optional array, finite where that command is sent instead (safe state)")
      .def("__repr__", [](const Table& t) {
        return fmt::format("<mrd.Table {}: {} terms, input {} in [{}, {}] V{}>", t.source,
                           t.table.model.num_terms,
                           t.table.model.channel_names[t.table.input_channel].data(), t.table.e_min,
                           t.table.e_max, t.table.has_envelope ? ", envelope" : "");
      });

  m.def(
      "read_table",
      [](const py::object& path) {
        const std::string p = PathOf(path);
        std::string reason;
        auto loaded = firmware::platform::LoadTableFile(p.c_str(), &reason);
        if (!loaded.ok()) Refuse(Printable(p) + ": " + reason, p);  // as mrd-hil words it
        return Table{loaded.value(), p};
      },
      py::arg("path"), "Reads and decodes a table file as the firmware does");
  m.def(
      "table_from_bytes",
      [](const py::bytes& image) {
        const std::string b = image;
        TableDiagnosis why;
        const auto decoded =
            DecodeTable(std::span<const std::uint8_t>(
                            reinterpret_cast<const std::uint8_t*>(b.data()), b.size()),
                        &why);
        if (!decoded.ok())
          throw BadInput("table image: " + firmware::platform::DescribeTableRefusal(why));
        return Table{decoded.value(), "bytes"};
      },
      py::arg("image"), "Decodes a table image (bytes)");
  m.def(
      "check_table",
      [](const py::object& path, const py::object& config) {
        const std::string p = PathOf(path);
        firmware::platform::FirmwareConfig fc;
        if (!config.is_none()) fc = LoadConfig(PathOf(config));
        const std::string why = firmware::platform::CheckTable(p.c_str(), fc);
        if (!why.empty()) Refuse(Printable(why, 4 * kMaxEchoChars), p);
      },
      py::arg("path"), py::arg("config") = py::none(),
      "`mrd-firmware --check-table PATH [--config CONFIG]`: returns None when the firmware "
      "accepts the table (with the config), else raises its reason");
}

}  // namespace mrd::python
