// Strict parsing of flag values: the whole string must be a number of the right kind, finite and in
// range. Each checker returns an empty string when the value is fine, else the reason it is not
// (the form CLI11 validators use), so that every bad value gets a message naming the rule it broke.
#pragma once

#include <glm/vec3.hpp>
#include <optional>
#include <string>

namespace tritrace::cli {

std::optional<long long> parse_integer(const std::string& text);
std::optional<double> parse_finite(const std::string& text);
// "X,Y,Z": three finite numbers separated by commas.
std::optional<glm::vec3> parse_vec3(const std::string& text);

std::string check_integer_in(const std::string& text, long long lo, long long hi);
std::string check_finite(const std::string& text);
std::string check_vec3(const std::string& text);

}  // namespace tritrace::cli
