// Argument conversion for the Python module; see convert.h for the rules.
#include "convert.h"

#include <algorithm>

#include "tritrace/job/setting_values.h"

namespace tritrace::python {
namespace {

std::string type_name(const py::handle& value) {
  return Py_TYPE(value.ptr())->tp_name;
}

bool is_bool(const py::handle& value) {
  return PyBool_Check(value.ptr()) ||
         py::isinstance(value, py::module_::import("numpy").attr("bool_"));
}

// An int or NumPy integer (anything with __index__ but a bool) as its decimal digits.
std::optional<std::string> integer_text(const py::handle& value) {
  if (is_bool(value) || !PyIndex_Check(value.ptr())) return std::nullopt;
  const py::object index = py::reinterpret_steal<py::object>(PyNumber_Index(value.ptr()));
  if (!index) throw py::error_already_set();
  return py::str(index).cast<std::string>();
}

// An int, float or NumPy real scalar as the text the CLI's number parsers read back exactly.
std::optional<std::string> number_text(const py::handle& value) {
  if (std::optional<std::string> digits = integer_text(value)) return digits;
  if (is_bool(value)) return std::nullopt;
  if (PyFloat_Check(value.ptr()) ||
      py::isinstance(value, py::module_::import("numpy").attr("floating"))) {
    return format_double(value.cast<double>());
  }
  return std::nullopt;
}

std::string vec3_text(const char* name, const py::object& value) {
  if (py::isinstance<py::str>(value) || py::isinstance<py::bytes>(value)) {
    raise_type_error(std::string(name) + ": must be three numbers, got " + type_name(value));
  }
  const py::array array = py::module_::import("numpy").attr("asarray")(value);
  const char kind = array.dtype().kind();
  if (array.ndim() != 1 || (kind != 'f' && kind != 'i' && kind != 'u')) {
    raise_type_error(std::string(name) + ": must be a sequence of three numbers, got " +
                     type_name(value));
  }
  std::string text;
  for (py::ssize_t i = 0; i < array.shape(0); ++i) {
    if (i > 0) text += ",";
    text += *number_text(array.attr("__getitem__")(i));
  }
  return text;
}

// numpy.asarray(value), refusing dtypes that are not real numbers.
py::array numeric_array(const char* name, const py::object& value, bool integers_only) {
  const py::array array = py::module_::import("numpy").attr("asarray")(value);
  const char kind = array.dtype().kind();
  const bool ok =
      integers_only ? (kind == 'i' || kind == 'u') : (kind == 'f' || kind == 'i' || kind == 'u');
  if (!ok) {
    raise_type_error(std::string(name) + ": must be an array of " +
                     (integers_only ? "integers" : "numbers") + ", got dtype " +
                     std::string(py::str(array.dtype())));
  }
  return array;
}

template <typename T>
py::array_t<T> converted(const char* name, const py::array& array, const char* dtype) {
  auto out = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(array);
  if (!out) raise_type_error(std::string(name) + ": cannot be converted to " + dtype);
  return out;
}

}  // namespace

std::string python_name(const std::string& flag) {
  std::string name = flag.starts_with("--") ? flag.substr(2) : flag;
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

std::string python_message(const std::string& cli_message) {
  if (!cli_message.starts_with("--")) return cli_message;
  const size_t colon = cli_message.find(':');
  if (colon == std::string::npos) return cli_message;
  return python_name(cli_message.substr(0, colon)) + cli_message.substr(colon);
}

void raise_value_error(const Error& e) {
  throw py::value_error(python_message(e.what()));
}

void raise_type_error(const std::string& message) {
  throw py::type_error(message);
}

std::string FlagTexts::keyword(const char* flag, const char* name) {
  if (name == nullptr) return python_name(flag);
  renamed_.emplace_back(flag, name);
  return name;
}

void FlagTexts::add_int(const char* flag, const py::object& value, const char* name) {
  if (value.is_none()) return;
  const std::string key = keyword(flag, name);
  const std::optional<std::string> text = integer_text(value);
  if (!text) raise_type_error(key + ": must be an int, got " + type_name(value));
  args_.emplace_back(flag, *text);
}

void FlagTexts::add_number(const char* flag, const py::object& value, const char* name) {
  if (value.is_none()) return;
  const std::string key = keyword(flag, name);
  const std::optional<std::string> text = number_text(value);
  if (!text) raise_type_error(key + ": must be a number, got " + type_name(value));
  args_.emplace_back(flag, *text);
}

void FlagTexts::add_vec3(const char* flag, const py::object& value, const char* name) {
  if (value.is_none()) return;
  const std::string key = keyword(flag, name);
  args_.emplace_back(flag, vec3_text(key.c_str(), value));
}

void FlagTexts::add_string(const char* flag, const py::object& value, const char* name) {
  if (value.is_none()) return;
  const std::string key = keyword(flag, name);
  args_.emplace_back(flag, string_arg(key.c_str(), value));
}

JobSettings FlagTexts::parse() const {
  JobSettings settings;
  for (const auto& [flag, text] : args_) {
    for (const SettingRule& rule : setting_rules()) {
      if (flag != rule.flag) continue;
      settings.*rule.text = text;
      const std::string why = rule.check(text);
      if (why.empty()) break;
      for (const auto& [renamed, name] : renamed_) {
        if (renamed == flag) throw py::value_error(name + ": " + why);
      }
      throw py::value_error(python_name(flag) + ": " + why);
    }
  }
  return settings;
}

std::optional<glm::vec3> optional_vec3(const char* name, const py::object& value) {
  if (value.is_none()) return std::nullopt;
  const std::string text = vec3_text(name, value);
  const std::string why = check_vec3(text);
  if (!why.empty()) throw py::value_error(std::string(name) + ": " + why);
  return parse_vec3(text);
}

std::optional<double> optional_number(const char* name, const py::object& value) {
  if (value.is_none()) return std::nullopt;
  const std::optional<std::string> text = number_text(value);
  if (!text) raise_type_error(std::string(name) + ": must be a number, got " + type_name(value));
  const std::string why = check_finite(*text);
  if (!why.empty()) throw py::value_error(std::string(name) + ": " + why);
  return parse_finite(*text);
}

double number_arg(const char* name, const py::object& value) {
  if (!number_text(value)) {
    raise_type_error(std::string(name) + ": must be a number, got " + type_name(value));
  }
  const double x = PyFloat_AsDouble(value.ptr());
  if (x == -1.0 && PyErr_Occurred()) {
    PyErr_Clear();  // an int too large for a double
    throw py::value_error(std::string(name) + ": must be within the range of a double, got " +
                          std::string(py::str(value)));
  }
  return x;
}

std::string string_arg(const char* name, const py::object& value) {
  if (!py::isinstance<py::str>(value)) {
    raise_type_error(std::string(name) + ": must be a str, got " + type_name(value));
  }
  return value.cast<std::string>();
}

std::string path_arg(const char* name, const py::object& value) {
  const py::module_ os = py::module_::import("os");
  if (!py::isinstance<py::str>(value) && !py::isinstance<py::bytes>(value) &&
      !py::hasattr(value, "__fspath__")) {
    raise_type_error(std::string(name) + ": must be a str, bytes or os.PathLike, got " +
                     type_name(value));
  }
  return os.attr("fsdecode")(value).cast<std::string>();
}

py::array_t<float> float32_array(const char* name, const py::object& value) {
  return converted<float>(name, numeric_array(name, value, false), "float32");
}

py::array_t<int64_t> int64_array(const char* name, const py::object& value) {
  return converted<int64_t>(name, numeric_array(name, value, true), "int64");
}

}  // namespace tritrace::python
