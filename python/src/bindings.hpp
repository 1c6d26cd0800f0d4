#pragma once
// Shared parts of the Python module's bindings (python/src/): errors worded as the CLI words
// them, arrays in and out, JSON values as Python objects, paths, work that runs beside the
// interpreter while it watches for Ctrl-C. No algorithm lives here: every binding calls the
// toolkit's libraries.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "mrd/common/table.hpp"
#include "mrd/host/csv.hpp"
#include "mrd/host/input_error.hpp"

namespace mrd::python {

namespace py = pybind11;

// Raised in Python as OSError (FileNotFoundError, PermissionError, IsADirectoryError by the
// cause) carrying the CLI's text.
class FileError : public std::runtime_error {
 public:
  FileError(const std::string& text, int err, bool is_directory)
      : std::runtime_error(text), err_(err), is_directory_(is_directory) {}
  int err() const { return err_; }
  bool is_directory() const { return is_directory_; }

 private:
  int err_;
  bool is_directory_;
};

// Raised in Python as ValueError carrying the CLI's text (what it prints after "error: ").
class BadInput : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Registers the translation of FileError, BadInput and host::InputError.
void RegisterErrors();

// An InputError as the Python exception to raise: FileError when the file it names is one of
// `paths` (the files the caller was given; every one of them when it names none) and cannot be
// opened as a regular file (missing, unreadable, a directory, a FIFO), BadInput otherwise.
[[noreturn]] void Rethrow(const host::InputError& e, const std::vector<std::string>& paths);

// Runs f(), translating an InputError by Rethrow.
template <class F>
auto Checked(const std::vector<std::string>& paths, F&& f) {
  try {
    return f();
  } catch (const host::InputError& e) {
    Rethrow(e, paths);
  }
}

// str, bytes or os.PathLike: a file path.
bool IsPath(const py::handle& obj);
std::string PathOf(const py::handle& obj);

// Most values one array may hold: the rows of the largest data file the CLI reads
// (host::kMaxDataFileBytes of the shortest rows, "0,0\n").
inline constexpr std::size_t kMaxArrayValues = std::size_t{1} << 28;

// A copy of a one-dimensional array of real numbers (numpy array, list, pandas Series; ints
// and floats of any width) as doubles. BadInput naming `what` for another dtype (bool,
// complex, strings, objects), another number of dimensions, or more than kMaxArrayValues.
std::vector<double> ToDoubles(const py::handle& obj, const std::string& what);

// A numpy float64 array owning the vector's storage (no copy).
py::array_t<double> ToArray(std::vector<double>&& values);

// The JSON value as Python objects (dict, list, str, int, float, bool, None); a non-finite
// number becomes None, as the CLI's JSON prints it (null).
py::object FromJson(const nlohmann::json& j);

// Issues a Python warning of the category (raises when warnings are errors).
void Warn(PyObject* category, const std::string& text);

// Work that runs on a worker thread while this (the interpreter's) thread, without the GIL,
// waits for it: the work's progress lines reach Python here (on_line, with the GIL), and
// Ctrl-C is honoured: after each batch of lines and every ~50 ms the interpreter's thread
// checks for signals (PyErr_CheckSignals). On a signal, or an exception on_line raises, the work
// is cancelled (cancelled() turns true, on_cancel runs once), waited for, and that exception
// (KeyboardInterrupt) is raised in place of the work's result or error; an exception the work
// throws is rethrown here.
class Beside {
 public:
  // Worker side: hands a line to the interpreter's thread and waits until it was handled and
  // signals were checked after it. false once the work is cancelled.
  bool Say(std::string line);
  // Worker side, without waiting: the line is handled with the next batch.
  void Note(std::string line);
  bool cancelled();
  // Interpreter side: runs work() to its end as above.
  void Run(const std::function<void()>& work,
           const std::function<void(const std::string&)>& on_line,
           const std::function<void()>& on_cancel = {});

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::string> lines_;
  std::uint64_t said_ = 0;     // lines handed over so far
  std::uint64_t handled_ = 0;  // of them, handled (signals checked after them)
  bool done_ = false;
  bool cancelled_ = false;
};

// A data set: a CSV path (host::ReadCsv with the required columns; *paths gets the path) or a
// mapping of column names to arrays (dict, pandas DataFrame: host::MakeDataSet, named
// `source` in messages). TypeError for anything else.
host::DataSet DataOf(const py::handle& data, const std::vector<std::string>& required,
                     const std::string& source, std::vector<std::string>* paths);

// Writes text to path as the CLI writes its outputs (host::CheckOutputPath, WriteFileAtomic);
// OSError with the CLI's text when it cannot.
void SaveText(const std::string& path, const std::string& text);

// A coefficient table as the module's Table object (tables.cpp).
py::object TableObject(CoefficientTable table, std::string source);

// Registration of each part (module.cpp calls them).
void RegisterModels(py::module_& m);
void RegisterIdentify(py::module_& m);
void RegisterTables(py::module_& m);
void RegisterLogs(py::module_& m);
void RegisterRuns(py::module_& m);

}  // namespace mrd::python
