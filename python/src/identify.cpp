// SEM identification (host/sem.hpp, sem_family.hpp) from data files or arrays, with a spec file,
// a spec as a dict (the TOML of docs/spec.md as Python values) or the built-in default. It runs
// beside the interpreter: its progress lines reach a Python callable (mrd.identify: the logger
// "mrd"), and Ctrl-C stops it at the end of the iteration under way (KeyboardInterrupt).
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <toml++/toml.h>

#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "mrd/host/candidate_spec.hpp"
#include "mrd/host/invertibility.hpp"
#include "mrd/host/model_file.hpp"
#include "mrd/host/sem.hpp"
#include "mrd/host/sem_default.hpp"
#include "mrd/host/sem_family.hpp"

namespace mrd::python {
namespace {

constexpr const char* kSpecDictName = "spec (dict)";

// Thrown from the progress callback once Ctrl-C was seen: ends the identification.
struct Cancelled : std::exception {
  const char* what() const noexcept override { return "interrupted"; }
};

// A Python value as a TOML node (dict: table, list: array, bool, int, float, str).
toml::table TomlTable(const py::handle& dict, const std::string& where);

void TomlInsert(toml::array* arr, toml::table* tbl, const std::string& key, const py::handle& v,
                const std::string& where) {
  const auto put = [&](auto&& node) {
    if (arr != nullptr) {
      arr->push_back(std::forward<decltype(node)>(node));
    } else {
      tbl->insert_or_assign(key, std::forward<decltype(node)>(node));
    }
  };
  if (py::isinstance<py::bool_>(v)) {
    put(v.cast<bool>());
  } else if (py::isinstance<py::str>(v)) {
    put(v.cast<std::string>());
  } else if (py::isinstance<py::int_>(v) ||
             (py::hasattr(v, "__index__") && !py::isinstance<py::float_>(v))) {
    const py::object i = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
    if (!i) throw py::error_already_set();
    int overflow = 0;
    const long long value = PyLong_AsLongLongAndOverflow(i.ptr(), &overflow);
    if (overflow != 0) {
      throw BadInput(fmt::format("{}: {}: integer beyond 64 bits", kSpecDictName, where));
    }
    put(static_cast<std::int64_t>(value));
  } else if (py::isinstance<py::float_>(v) || py::hasattr(v, "__float__")) {
    put(py::float_(py::reinterpret_borrow<py::object>(v)).cast<double>());
  } else if (py::isinstance<py::dict>(v)) {
    put(TomlTable(v, where));
  } else if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    toml::array a;
    std::size_t i = 0;
    for (const py::handle item : v) {
      TomlInsert(&a, nullptr, "", item, where + "[" + std::to_string(i++) + "]");
    }
    put(std::move(a));
  } else {
    throw BadInput(
        fmt::format("{}: {}: a {} is not a TOML value (use dict, list, str, int, "
                    "float, bool)",
                    kSpecDictName, where, std::string(py::str(py::type::of(v).attr("__name__")))));
  }
}

toml::table TomlTable(const py::handle& dict, const std::string& where) {
  toml::table t;
  for (const auto& [k, v] : dict.cast<py::dict>()) {
    if (!py::isinstance<py::str>(k)) {
      throw BadInput(fmt::format("{}: {}: keys must be strings, got {}", kSpecDictName, where,
                                 std::string(py::repr(k))));
    }
    const std::string key = k.cast<std::string>();
    TomlInsert(nullptr, &t, key, v, where.empty() ? key : where + "." + key);
  }
  return t;
}

// The spec: None (the built-in specs, as `mrd identify` without --spec: nullopt), a path, or a
// dict.
std::optional<host::SemSpec> SpecOf(const py::handle& spec, std::vector<std::string>* paths) {
  if (spec.is_none()) return std::nullopt;
  if (IsPath(spec)) {
    const std::string path = PathOf(spec);
    paths->push_back(path);
    return Checked({path}, [&] { return host::LoadSemSpec(path); });
  }
  if (!py::isinstance<py::dict>(spec)) {
    throw py::type_error("spec: expected None, a spec file path or a dict, got " +
                         std::string(py::str(py::type::of(spec).attr("__name__"))));
  }
  std::ostringstream text;
  text << TomlTable(spec, "");
  const std::string toml = text.str();
  try {
    return host::ParseSemSpec(toml, kSpecDictName);
  } catch (const host::InputError& e) {
    // The line is one of the TOML text made from the dict: show it.
    std::string shown;
    if (e.line() > 0) {
      std::istringstream lines(toml);
      std::string line;
      for (std::size_t n = 0; n < e.line() && std::getline(lines, line); ++n) {
      }
      shown = fmt::format(" (line {} of the dict as TOML: {})", e.line(), line);
    }
    throw BadInput(e.what() + shown);
  }
}

// Data sets: one (path or mapping) or a list/tuple of them. names: as recorded in the model file.
std::vector<host::DataSet> DataSetsOf(const py::handle& data, const std::string& what,
                                      std::vector<std::string>* paths,
                                      std::vector<std::string>* names) {
  std::vector<py::handle> items;
  if (py::isinstance<py::list>(data) || py::isinstance<py::tuple>(data)) {
    for (const py::handle h : data) items.push_back(h);
  } else if (!data.is_none()) {
    items.push_back(data);
  }
  std::vector<host::DataSet> out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::string source = items.size() == 1 ? what : fmt::format("{}[{}]", what, i);
    out.push_back(DataOf(items[i], {}, source, paths));
    names->push_back(out.back().path);
  }
  return out;
}

template <class T>
void CheckRange(const char* name, const std::optional<T>& v, T lo, T hi) {
  if (v && !(*v >= lo && *v <= hi)) {
    throw BadInput(fmt::format("{}: {} is outside [{}, {}]", name, *v, lo, hi));
  }
}

// The progress line of `mrd identify` for one iteration.
std::string IterationLine(const host::SemIteration& it) {
  std::string s = fmt::format(
      "iteration {:3d}: {:2d} terms, J {:.6g}, validation J [{:.6g}], {:.2f} s", it.iteration,
      it.terms.size(), it.j, fmt::join(it.validation_j, ", "), it.elapsed_s);
  if (it.stress.checked) {
    s += fmt::format(", stress {} (peak {:.3g}, {} candidates rejected)",
                     it.stress.pass ? "pass" : "FAIL", it.stress.peak, it.stress_rejected);
  }
  return s;
}

host::ModelFile Identify(const py::object& data, const py::object& spec, const py::object& validate,
                         int threads, std::optional<int> max_iterations,
                         std::optional<double> threshold, std::optional<double> target_j,
                         std::optional<std::string> strategy,
                         std::optional<std::vector<std::string>> initial,
                         std::optional<std::int64_t> max_candidates, const py::object& progress) {
  // The CLI's option ranges.
  CheckRange("threshold", threshold, 0.0, 99.999);
  CheckRange("max_iterations", max_iterations, 0, 100000);
  CheckRange("max_candidates", max_candidates, std::int64_t{1}, std::int64_t{2000000000});
  CheckRange("threads", std::optional<int>(threads), 0, 256);
  if (target_j && !std::isfinite(*target_j)) throw BadInput("target_j: not a finite number");
  if (strategy && *strategy != "best" && *strategy != "first") {
    throw BadInput("strategy: '" + *strategy + "' is not best or first");
  }
  std::vector<std::string> paths, id_names, val_names;
  const std::optional<host::SemSpec> sem_spec = SpecOf(spec, &paths);
  const std::vector<host::DataSet> id = DataSetsOf(data, "data", &paths, &id_names);
  if (id.empty()) throw BadInput("data: no identification data");
  const std::vector<host::DataSet> val = DataSetsOf(validate, "validate", &paths, &val_names);

  host::SemOptions so;
  if (strategy) so.strategy = *strategy == "first" ? host::Strategy::kFirst : host::Strategy::kBest;
  so.threshold_percent = threshold;
  so.max_iterations = max_iterations;
  so.target_j = target_j;
  so.max_candidates = max_candidates;
  if (initial && !initial->empty()) so.initial = *initial;
  so.threads =
      threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));

  // Each progress line waits until Python has it and signals were checked after it, so Ctrl-C
  // stops the identification at the next iteration reported.
  Beside beside;
  so.progress = [&](const host::SemIteration& it) {
    if (!beside.Say(IterationLine(it))) throw Cancelled();
  };
  const auto member = [&](std::size_t i, std::size_t n, const std::vector<std::string>& regs,
                          const host::FamilyCombination& c) {
    if (!beside.Say(host::FamilyProgressLine(i, n, regs, c))) throw Cancelled();
  };
  const auto on_line = [&](const std::string& line) {
    if (!progress.is_none()) progress(line);
  };
  // Without a spec, as mrd identify: a line as each built-in spec starts and ends.
  const auto spec_line = [&](std::size_t i, std::size_t n, const host::SpecCandidate& c,
                             bool done) {
    if (!beside.Say(host::SpecProgressLine(i, n, c, done))) throw Cancelled();
  };
  host::DefaultIdentification di;
  Checked(paths, [&] {
    beside.Run(
        [&] {
          if (sem_spec) {
            di.identification = host::IdentifyFamilies(*sem_spec, id, val, so, member);
          } else {
            di = host::IdentifyDefault(id, val, so, member, spec_line);
          }
        },
        on_line);
  });
  const host::FamilyIdentification& fi = di.identification;
  host::ModelFile mf = host::MakeModelFile(fi.spec, fi.result);
  mf.family = fi.family;
  mf.spec_choice = di.choice;
  mf.identification_data = id_names;
  mf.validation_data = val_names;
  // As mrd identify: the selected iteration's invertibility on the identification data.
  (void)host::RecordInvertibility(&mf, id);
  if (!progress.is_none()) {
    const host::SemIteration& sel = mf.Iteration(mf.selected);
    progress(
        fmt::format("{} candidates, {} iterations, selected iteration {} ({} terms, J {:.6g}; {})",
                    fi.result.num_candidates, fi.result.iterations.size() - 1, mf.selected,
                    sel.terms.size(), sel.j, mf.selection_rule));
  }
  return mf;
}

}  // namespace

void RegisterIdentify(py::module_& m) {
  m.def("_identify", &Identify, py::arg("data"), py::arg("spec"), py::arg("validate"),
        py::arg("threads"), py::arg("max_iterations"), py::arg("threshold"), py::arg("target_j"),
        py::arg("strategy"), py::arg("initial"), py::arg("max_candidates"), py::arg("progress"));
  m.def(
      "spec_toml",
      [](const py::dict& spec) {
        std::ostringstream text;
        text << TomlTable(spec, "");
        return text.str();
      },
      py::arg("spec"), "The TOML text identify() makes of a spec given as a dict");
}

}  // namespace mrd::python
