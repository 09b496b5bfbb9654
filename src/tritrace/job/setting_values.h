// Strict parsing of setting values (flag values, and the Python module's arguments written as
// flag values): the whole string must be a number of the right kind, finite and in range. Each
// checker returns an empty string when the value is fine, else the reason it is not (the form CLI11
// validators use), so that every bad value gets a message naming the rule it broke. The formatters
// write numbers that these parsers read back exactly, so that a printed command line reproduces a
// view bit for bit.
#pragma once

#include <glm/vec3.hpp>
#include <optional>
#include <string>

namespace tritrace {

std::optional<long long> parse_integer(const std::string& text);
std::optional<double> parse_finite(const std::string& text);
// A finite number within float range, read as a double and rounded to float.
std::optional<float> parse_float(const std::string& text);
// "X,Y,Z": three finite numbers separated by commas.
std::optional<glm::vec3> parse_vec3(const std::string& text);

std::string check_integer_in(const std::string& text, long long lo, long long hi);
std::string check_finite(const std::string& text);
std::string check_vec3(const std::string& text);
// --distance: a float greater than 0.
std::string check_distance(const std::string& text);

// The shortest text that parse_finite reads back as exactly `value` (std::to_chars' shortest form
// round-trips by definition).
std::string format_double(double value);
// The shortest text that parse_float and parse_vec3 read back as exactly `value`.
std::string format_float(float value);
std::string format_vec3(glm::vec3 value);  // "X,Y,Z", each as format_float

inline constexpr long long kMaxThreads = 1024;

// The names the render and bench commands accept, and the checks on them.
std::string kernel_list();  // "inverse|cramer|..."
std::string accel_list();   // the accels this build has
std::string check_builtin_scene(const std::string& name);
std::string check_accel(const std::string& name);
std::string check_bvh_build(const std::string& name);  // sah or morton
std::string check_kernel(const std::string& name);

}  // namespace tritrace
