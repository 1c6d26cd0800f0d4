# Finds what the Python module needs and sets MRD_PYTHON_MODULE (included from the top-level
# CMakeLists.txt, so tests/ sees the result and Python3_EXECUTABLE).
# Debian's interpreter, whose python3-numpy and python3-pytest toolchain/setup.sh installs, not
# whichever python3 is first on PATH (a pyenv or virtualenv one lacks them); give
# -DPython3_EXECUTABLE=... to choose another.
if(NOT DEFINED Python3_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(Python3_EXECUTABLE /usr/bin/python3)
endif()
find_package(Python3 3.9 COMPONENTS Interpreter Development.Module NumPy)
if(Python3_FOUND)
  find_package(pybind11 2.6 CONFIG QUIET)
endif()
if(Python3_FOUND AND Python3_NumPy_FOUND AND pybind11_FOUND)
  set(MRD_PYTHON_MODULE ON)
  message(STATUS "Python module mrd: Python ${Python3_VERSION} (${Python3_EXECUTABLE}), "
                 "numpy ${Python3_NumPy_VERSION}, pybind11 ${pybind11_VERSION}")
else()
  message(WARNING "Python module mrd not built: needs python3-dev, python3-numpy and "
                  "pybind11-dev (bash toolchain/setup.sh installs them), or -DMRD_BUILD_PYTHON=OFF")
endif()
