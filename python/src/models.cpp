// Model files (host/model_file.hpp): load, save, the iterations and their terms, free-run
// simulation on a data file or on arrays (the numbers of `mrd simulate --json`), the operating
// envelope check, and the coefficient table of an iteration (`mrd export`).
#include <fmt/format.h>

#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "mrd/host/atomic_write.hpp"
#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/command_range.hpp"
#include "mrd/host/invertibility.hpp"
#include "mrd/host/model_export.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/model_judge.hpp"

namespace mrd::python {
namespace {

using host::ModelFile;

PyObject* g_envelope_warning = nullptr;       // mrd.EnvelopeWarning (a new reference, kept)
PyObject* g_invertibility_warning = nullptr;  // mrd.InvertibilityWarning (kept)

bool IsMapping(const py::handle& obj) {
  return py::isinstance<py::dict>(obj) ||
         (py::hasattr(obj, "keys") && py::hasattr(obj, "__getitem__"));
}

int IterationOf(const ModelFile& m, const std::optional<int>& iteration) {
  const int k = iteration.value_or(m.selected);
  Checked({m.path}, [&] { (void)m.Iteration(k); });  // InputError "no iteration K"
  return k;
}

std::vector<std::string> TermNames(const ModelFile& m, const std::optional<int>& iteration) {
  const host::SemIteration& it = m.Iteration(IterationOf(m, iteration));
  std::vector<std::string> out;
  for (const host::SemTerm& t : it.terms) out.push_back(host::TermName(m.spec, t));
  return out;
}

py::list Channels(const ModelFile& m) {
  py::list out;
  for (const host::ChannelInfo& c : m.channels) {
    py::dict d;
    d["name"] = c.name;
    d["offset"] = c.offset;
    d["scale"] = c.scale;
    d["min"] = c.has_range ? py::object(py::float_(c.min)) : py::object(py::none());
    d["max"] = c.has_range ? py::object(py::float_(c.max)) : py::object(py::none());
    out.append(d);
  }
  return out;
}

// `mrd simulate --model M --data D --json` as a dict, plus the arrays t, y and y_sim (y the
// model's output). Envelope warnings as mrd.EnvelopeWarning, the CLI's stderr lines.
py::dict Simulate(const ModelFile& m, const py::handle& data, const std::optional<int>& iteration) {
  const int k = IterationOf(m, iteration);
  std::vector<std::string> paths{m.path};
  const host::DataSet ds = DataOf(data, m.spec.Signals(), "data", &paths);
  std::vector<double> ysim;
  nlohmann::json j;
  std::vector<std::string> warnings;
  std::string not_invertible;  // the CLI's invertibility warning, when it fails
  Checked(paths, [&] {
    const py::gil_scoped_release release;
    const host::SimMetrics metrics = host::SimulateModel(m, k, ds, &ysim);
    const std::vector<host::EnvelopeCheck> env = host::CheckEnvelope(m, ds);
    warnings = host::EnvelopeWarnings(m.path, ds.path, env);
    j = host::MetricsJson(m, metrics);
    j["iteration"] = k;
    j["terms"] = m.Iteration(k).terms.size();
    j["envelope"] = host::EnvelopeJson(env);
    j["outside_envelope"] = host::AnyOutside(env);
    // As mrd simulate: invertibility in the command on this data's states and the grid.
    if (!host::ModelCommand(m).empty()) {
      const host::InvertibilityReport inv =
          host::CheckModelInvertibility(m, k, std::span<const host::DataSet>(&ds, 1));
      j["invertibility"] = host::InvertibilityJson(inv);
      if (!inv.pass()) {
        not_invertible =
            fmt::format("{} on {}: {}", m.path, ds.path, host::InvertibilitySummary(inv));
      }
    }
  });
  for (std::string w : warnings) {
    if (w.rfind("warning: ", 0) == 0) w.erase(0, 9);
    Warn(g_envelope_warning, w);
  }
  if (!not_invertible.empty()) Warn(g_invertibility_warning, not_invertible);
  py::dict out = FromJson(j).cast<py::dict>();
  const std::string& y = m.spec.output;
  out["t"] = ToArray(std::vector<double>(ds.Column("t")));
  out[py::str(y)] = ToArray(std::vector<double>(ds.Column(y)));
  out[py::str(y + "_sim")] = ToArray(std::move(ysim));
  return out;
}

py::object CheckEnvelopeOf(const ModelFile& m, const py::handle& data) {
  std::vector<std::string> paths{m.path};
  const host::DataSet ds = DataOf(data, {}, "data", &paths);
  return FromJson(Checked(paths, [&] { return host::EnvelopeJson(host::CheckEnvelope(m, ds)); }));
}

}  // namespace

host::DataSet DataOf(const py::handle& data, const std::vector<std::string>& required,
                     const std::string& source, std::vector<std::string>* paths) {
  if (IsPath(data)) {
    const std::string path = PathOf(data);
    paths->push_back(path);
    return Checked({path}, [&] { return host::ReadCsv(path, required); });
  }
  if (!IsMapping(data)) {
    throw py::type_error(source +
                         ": expected a CSV file path or a mapping of column names to arrays "
                         "(dict, pandas DataFrame), got " +
                         std::string(py::str(py::type::of(data).attr("__name__"))));
  }
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;
  for (const py::handle key : data.attr("keys")()) {
    if (!py::isinstance<py::str>(key)) {
      throw BadInput(source + ": column names must be strings, got " + std::string(py::repr(key)));
    }
    names.push_back(key.cast<std::string>());
    columns.push_back(ToDoubles(data[key], source + ": column '" + names.back() + "'"));
  }
  return Checked({}, [&] {
    return host::MakeDataSet(source, std::move(names), std::move(columns), required);
  });
}

void SaveText(const std::string& path, const std::string& text) {
  try {
    host::CheckOutputPath(path);
    host::WriteFileAtomic(path, text);
  } catch (const std::exception& e) {  // InputError (destination) or the system's error
    throw FileError(e.what(), 0, false);
  }
}

void RegisterModels(py::module_& m) {
  g_envelope_warning = PyErr_NewExceptionWithDoc(
      "mrd.EnvelopeWarning",
      "Data outside the operating envelope of a model's identification data (as `mrd "
      "simulate` warns on stderr).",
      PyExc_UserWarning, nullptr);
  m.attr("EnvelopeWarning") = py::handle(g_envelope_warning);
  g_invertibility_warning = PyErr_NewExceptionWithDoc(
      "mrd.InvertibilityWarning",
      "A model whose force falls with its command somewhere on the data or its envelope (as "
      "`mrd simulate` warns on stderr): a controller inverting it may ask for the wrong "
      "command.",
      PyExc_UserWarning, nullptr);
  m.attr("InvertibilityWarning") = py::handle(g_invertibility_warning);

  py::class_<ModelFile>(m, "Model",
                        "An identified model file (mrd identify, mrd.identify): the spec, every "
                        "iteration of the search and the selected one.")
      .def_readonly("path", &ModelFile::path, "File it was loaded from ('' when identified here)")
      .def_property_readonly(
          "output", [](const ModelFile& mf) { return mf.spec.output; },
          "Name of the output signal (the force, f)")
      .def_property_readonly(
          "inputs",
          [](const ModelFile& mf) {
            std::vector<std::string> s = mf.spec.Signals();
            s.erase(s.begin());
            return s;
          },
          "Names of the input signals")
      .def_readonly("selected", &ModelFile::selected, "The selected iteration")
      .def_readonly("selection_rule", &ModelFile::selection_rule, "How it was selected, in words")
      .def_readonly("num_candidates", &ModelFile::num_candidates)
      .def_property_readonly("warmup_samples", &ModelFile::warmup_samples,
                             "Leading samples that seed a simulation (the spec's largest delay)")
      .def_readonly("identification_data", &ModelFile::identification_data)
      .def_readonly("validation_data", &ModelFile::validation_data)
      .def_property_readonly("channels", &Channels,
                             "Per signal (output first): name, offset, scale, and the range of "
                             "the identification data (min, max; None when not recorded)")
      .def_property_readonly(
          "iterations",
          [](const ModelFile& mf) {
            return FromJson(nlohmann::json::parse(host::ModelFileToJson(mf))["iterations"]);
          },
          "Every iteration as in the model file: iteration, J, validation_J, terms with "
          "coefficients (normalised units) and factors, stress verdict")
      .def("terms", &TermNames, py::arg("iteration") = py::none(),
           "Terms of an iteration (default: the selected one) as text, e.g. 'y(k-1)^2*u2(k)'")
      .def(
          "coefficients",
          [](const ModelFile& mf, const std::optional<int>& iteration) {
            return ToArray(
                std::vector<double>(mf.Iteration(IterationOf(mf, iteration)).coefficients));
          },
          py::arg("iteration") = py::none(), "Coefficients of an iteration (normalised units)")
      .def("to_json", &host::ModelFileToJson, "The model file's JSON text")
      .def(
          "save",
          [](const ModelFile& mf, const py::object& path) {
            SaveText(PathOf(path), host::ModelFileToJson(mf));
          },
          py::arg("path"), "Writes the model file (atomically, as mrd identify does)")
      .def("simulate", &Simulate, py::arg("data"), py::arg("iteration") = py::none(),
           "Free run on a data set (CSV path, or dict/DataFrame of arrays with t and the "
           "model's signals): the numbers of `mrd simulate --json` and the arrays t, the "
           "measured output and <output>_sim")
      .def("check_envelope", &CheckEnvelopeOf, py::arg("data"),
           "Each input with a recorded range against the data: envelope, data range, samples "
           "outside, largest excursion (as the `envelope` of `mrd simulate --json`)")
      .def(
          "table",
          [](const ModelFile& mf, const std::optional<int>& iteration, const std::string& input,
             const std::optional<double>& e_min, const std::optional<double>& e_max) {
            const int k = IterationOf(mf, iteration);
            // As mrd export: the command range the data reached (or the one given), the
            // invertibility verdict recorded in the table (not refused: Table.invertibility).
            CoefficientTable t = Checked({mf.path}, [&] {
              return host::ExportCheckedTable(mf, {k, input, e_min, e_max, ""}).table;
            });
            return TableObject(t, mf.path.empty() ? std::string("model") : mf.path);
          },
          py::arg("iteration") = py::none(), py::arg("input") = "E", py::arg("e_min") = py::none(),
          py::arg("e_max") = py::none(),
          "The coefficient table of an iteration, as `mrd export` makes it (the command range "
          "the data reached unless given, the operating envelope when the model has one, the "
          "invertibility verdict)")
      .def("__repr__", [](const ModelFile& mf) {
        return fmt::format("<mrd.Model {} selected iteration {} ({} terms) of {}>",
                           mf.path.empty() ? std::string("(identified)") : mf.path, mf.selected,
                           mf.Iteration(mf.selected).terms.size(), mf.iterations.size());
      });

  m.def(
      "load_model",
      [](const py::object& path) {
        const std::string p = PathOf(path);
        return Checked({p}, [&] { return host::LoadModelFile(p); });
      },
      py::arg("path"), "Reads a model file (JSON) written by mrd identify or Model.save");
  m.def(
      "_read_data",
      [](const py::object& path) {
        const std::string p = PathOf(path);
        host::DataSet ds = Checked({p}, [&] { return host::ReadCsv(p); });
        py::dict out;
        for (std::size_t i = 0; i < ds.names.size(); ++i) {
          out[py::str(ds.names[i])] = ToArray(std::move(ds.columns[i]));
        }
        return out;
      },
      py::arg("path"));
  m.def("simulate", &Simulate, py::arg("model"), py::arg("data"), py::arg("iteration") = py::none(),
        "Model.simulate as a function");
}

}  // namespace mrd::python
