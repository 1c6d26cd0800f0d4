// mrd._mrd: the extension module under the `mrd` package (python/mrd/__init__.py).
#include "bindings.hpp"

PYBIND11_MODULE(_mrd, m) {
  m.doc() =
      "The MRD toolkit's libraries from Python: model files, simulation, identification, "
      "coefficient tables and the firmware's inversion, per-period logs, HIL runs "
      "(docs/python.md).";
  m.attr("__version__") = MRD_VERSION;
  m.attr("bin_dir") = MRD_BIN_DIR;  // where this build's programs are (mrd-firmware)
  mrd::python::RegisterErrors();
  mrd::python::RegisterTables(m);
  mrd::python::RegisterModels(m);
  mrd::python::RegisterIdentify(m);
  mrd::python::RegisterLogs(m);
  mrd::python::RegisterRuns(m);
}
