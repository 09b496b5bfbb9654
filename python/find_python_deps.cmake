# Finds what the Python module needs: Debian's python3 with its headers and NumPy, and Debian's
# pybind11 (scripts/install-deps.sh installs python3-dev, python3-numpy and pybind11-dev). Sets
# TRITRACE_PYTHON_FOUND; without them the build goes on without the module and says why.
#
# Debian's pybind11 and NumPy are built for Debian's /usr/bin/python3, which a python3 earlier on
# PATH (pyenv, a virtual environment) may not be, so that interpreter is the default;
# -DPython_EXECUTABLE=... chooses another (it then needs its own NumPy).
if(NOT DEFINED Python_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(Python_EXECUTABLE /usr/bin/python3 CACHE FILEPATH "The Python the module is built for")
endif()
find_package(Python 3.8 QUIET COMPONENTS Interpreter Development.Module NumPy)
if(Python_FOUND)
  find_package(pybind11 2.6 CONFIG QUIET)
endif()

set(TRITRACE_PYTHON_FOUND OFF)
if(NOT Python_FOUND)
  message(STATUS "tritrace: building without the Python module (no Python 3 with headers and "
                 "NumPy; install python3-dev and python3-numpy)")
elseif(NOT pybind11_FOUND)
  message(STATUS "tritrace: building without the Python module (no pybind11; install "
                 "pybind11-dev)")
else()
  set(TRITRACE_PYTHON_FOUND ON)
  message(STATUS "tritrace: Python module for ${Python_EXECUTABLE} (${Python_VERSION}), "
                 "pybind11 ${pybind11_VERSION}, NumPy ${Python_NumPy_VERSION}")
endif()
