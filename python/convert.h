// Python values in, checked: the keyword arguments the module shares with the CLI become the render
// job's setting texts and go through the library's rule for each (tritrace/job/job_settings.h),
// which the CLI's flags use too, so that they accept the same values and fail with the same
// reasons; arrays become C-contiguous float32 (without a
// copy when they already are) and are shape-checked. Wrong types raise TypeError, bad values and
// shapes ValueError, each message starting with the argument's name.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/job/job_settings.h"

namespace tritrace::python {

namespace py = pybind11;

// "--max-depth: reason" -> "max_depth: reason": a CLI message with the flag as the Python keyword.
std::string python_message(const std::string& cli_message);
// tritrace::Error as the Python exception a bad argument raises: ValueError, the subject renamed
// as above.
[[noreturn]] void raise_value_error(const Error& e);
[[noreturn]] void raise_type_error(const std::string& message);

// The flag texts of keyword arguments, in the form the CLI reads them; None adds nothing.
class FlagTexts {
 public:
  // flag is the CLI's ("--spp"); messages name the keyword `name`, by default python_name(flag).
  void add_int(const char* flag, const py::object& value, const char* name = nullptr);
  void add_number(const char* flag, const py::object& value, const char* name = nullptr);
  void add_vec3(const char* flag, const py::object& value, const char* name = nullptr);
  void add_string(const char* flag, const py::object& value, const char* name = nullptr);
  // The settings, each text checked by its rule; ValueError naming the keyword on failure.
  JobSettings parse() const;

 private:
  // The keyword for `flag`, remembering a name that differs from python_name(flag).
  std::string keyword(const char* flag, const char* name);

  std::vector<std::pair<std::string, std::string>> args_;     // flag, text
  std::vector<std::pair<std::string, std::string>> renamed_;  // flag, keyword
};

// The keyword's name for a flag: "--max-depth" -> "max_depth".
std::string python_name(const std::string& flag);

// Exact conversions for arguments that are not CLI flags; the same type rules as FlagTexts.
std::optional<glm::vec3> optional_vec3(const char* name, const py::object& value);
std::optional<double> optional_number(const char* name, const py::object& value);
// Any number (int, float, NumPy real scalar; not bool), infinities and NaN included.
double number_arg(const char* name, const py::object& value);
std::string string_arg(const char* name, const py::object& value);
// A path: str, bytes or os.PathLike (TypeError otherwise).
std::string path_arg(const char* name, const py::object& value);

// An array of numbers (any real dtype, or anything numpy.asarray makes one of) as C-contiguous
// float32: the same array when it already is one, else one converted copy. TypeError for other
// dtypes (bool, complex, strings, objects).
py::array_t<float> float32_array(const char* name, const py::object& value);
// The same for integer arrays as int64 (TypeError for floats and other dtypes).
py::array_t<int64_t> int64_array(const char* name, const py::object& value);

}  // namespace tritrace::python
