// Shared parts of the bindings (bindings.hpp).
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <string_view>
#include <thread>

#include "bindings.hpp"
#include "mrd/common/input_file.hpp"

namespace mrd::python {

void RegisterErrors() {
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const FileError& e) {
      PyObject* type = PyExc_OSError;
      if (e.is_directory() || e.err() == EISDIR) {
        type = PyExc_IsADirectoryError;
      } else if (e.err() == ENOENT) {
        type = PyExc_FileNotFoundError;
      } else if (e.err() == EACCES || e.err() == EPERM) {
        type = PyExc_PermissionError;
      }
      PyErr_SetString(type, e.what());
    } catch (const BadInput& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const host::InputError& e) {  // a binding that named no files
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
}

void Rethrow(const host::InputError& e, const std::vector<std::string>& paths) {
  std::vector<std::string> probe;
  if (e.file().empty()) {
    probe = paths;
  } else if (std::find(paths.begin(), paths.end(), e.file()) != paths.end()) {
    probe = {e.file()};
  }
  for (const std::string& path : probe) {
    if (path.empty()) continue;
    const InputFile f = OpenInputFile(path.c_str(), std::numeric_limits<std::uint64_t>::max());
    if (f.fd >= 0) {
      ::close(f.fd);
      continue;
    }
    throw FileError(e.what(), f.error, std::string_view(f.kind) == "a directory");
  }
  throw BadInput(e.what());
}

bool IsPath(const py::handle& obj) {
  return py::isinstance<py::str>(obj) || py::isinstance<py::bytes>(obj) ||
         py::hasattr(obj, "__fspath__");
}

std::string PathOf(const py::handle& obj) {
  const py::object p = py::module_::import("os").attr("fspath")(obj);
  std::string path =
      py::isinstance<py::bytes>(p) ? std::string(p.cast<py::bytes>()) : p.cast<std::string>();
  // A NUL would cut the path short at the system call: another file than the one named.
  if (path.find('\0') != std::string::npos) throw BadInput("path contains a NUL character");
  if (path.empty()) throw FileError("empty path", ENOENT, false);
  return path;
}

std::vector<double> ToDoubles(const py::handle& obj, const std::string& what) {
  const py::array a = py::array::ensure(obj);
  if (!a) throw BadInput(what + ": not an array of numbers");
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    throw BadInput(what + ": dtype " + std::string(py::str(a.dtype())) +
                   " is not a real number type (int or float)");
  }
  if (a.ndim() != 1) {
    throw BadInput(what + ": expected a one-dimensional array, got " + std::to_string(a.ndim()) +
                   " dimensions");
  }
  const auto n = static_cast<std::size_t>(a.size());
  if (n > kMaxArrayValues) {
    throw BadInput(what + ": " + std::to_string(n) + " values, more than the " +
                   std::to_string(kMaxArrayValues) + " a data file can hold");
  }
  const auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!d) throw BadInput(what + ": cannot be read as float64");
  std::vector<double> out(n);
  if (n > 0) std::memcpy(out.data(), d.data(), n * sizeof(double));
  return out;
}

py::array_t<double> ToArray(std::vector<double>&& values) {
  auto* owned = new std::vector<double>(std::move(values));
  const py::capsule free(owned, [](void* p) { delete static_cast<std::vector<double>*>(p); });
  return py::array_t<double>({owned->size()}, {sizeof(double)}, owned->data(), free);
}

py::object FromJson(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(j.get<std::int64_t>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<std::uint64_t>());
    case nlohmann::json::value_t::number_float: {
      const double v = j.get<double>();
      return std::isfinite(v) ? py::object(py::float_(v)) : py::object(py::none());
    }
    case nlohmann::json::value_t::string:
      return py::str(j.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list out;
      for (const auto& v : j) out.append(FromJson(v));
      return out;
    }
    case nlohmann::json::value_t::object: {
      py::dict out;
      for (const auto& [k, v] : j.items()) out[py::str(k)] = FromJson(v);
      return out;
    }
    default:
      return py::none();
  }
}

void Warn(PyObject* category, const std::string& text) {
  if (PyErr_WarnEx(category, text.c_str(), 2) != 0) throw py::error_already_set();
}

bool Beside::Say(std::string line) {
  std::unique_lock<std::mutex> lock(mu_);
  lines_.push_back(std::move(line));
  const std::uint64_t mine = ++said_;
  cv_.notify_all();
  cv_.wait(lock, [&] { return handled_ >= mine; });
  return !cancelled_;
}

void Beside::Note(std::string line) {
  const std::lock_guard<std::mutex> lock(mu_);
  lines_.push_back(std::move(line));
  ++said_;
}

bool Beside::cancelled() {
  const std::lock_guard<std::mutex> lock(mu_);
  return cancelled_;
}

void Beside::Run(const std::function<void()>& work,
                 const std::function<void(const std::string&)>& on_line,
                 const std::function<void()>& on_cancel) {
  std::exception_ptr work_error;
  std::thread worker([&] {
    try {
      work();
    } catch (...) {
      work_error = std::current_exception();
    }
    const std::lock_guard<std::mutex> lock(mu_);
    done_ = true;
    cv_.notify_all();
  });
  // What stops the wait early: a signal's Python error, or an exception on_line raised.
  std::exception_ptr stop;
  for (;;) {
    std::vector<std::string> now;
    bool finished = false;
    std::uint64_t upto = 0;
    {
      const py::gil_scoped_release release;
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait_for(lock, std::chrono::milliseconds(50), [&] { return done_ || !lines_.empty(); });
      now.swap(lines_);
      finished = done_;
      upto = said_;
    }
    try {
      for (const std::string& line : now) {
        if (!stop) on_line(line);
      }
      if (!finished && !stop && PyErr_CheckSignals() != 0) throw py::error_already_set();
    } catch (...) {
      if (!stop) {
        stop = std::current_exception();
        {
          const std::lock_guard<std::mutex> lock(mu_);
          cancelled_ = true;
        }
        if (on_cancel) {
          try {
            on_cancel();
          } catch (...) {  // the first exception is the one raised
          }
        }
      }
    }
    {
      const std::lock_guard<std::mutex> lock(mu_);
      handled_ = upto;
      cv_.notify_all();
    }
    if (finished) break;
  }
  worker.join();
  if (stop) std::rethrow_exception(stop);
  if (work_error) std::rethrow_exception(work_error);
}

}  // namespace mrd::python
