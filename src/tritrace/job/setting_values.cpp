// Setting value parsing with std::from_chars, which accepts no leading spaces, signs like '+', or
// trailing junk.
#include "tritrace/job/setting_values.h"

#include <charconv>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include "tritrace/accel/make_accel.h"
#include "tritrace/geometry/intersect.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {

std::optional<long long> parse_integer(const std::string& text) {
  long long value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || text.empty()) return std::nullopt;
  return value;
}

std::optional<double> parse_finite(const std::string& text) {
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || text.empty() || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::optional<float> parse_float(const std::string& text) {
  const std::optional<double> x = parse_finite(text);
  if (!x || std::abs(*x) > std::numeric_limits<float>::max()) return std::nullopt;
  return static_cast<float>(*x);
}

std::optional<glm::vec3> parse_vec3(const std::string& text) {
  glm::vec3 v(0.0f);
  size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const size_t comma = text.find(',', start);
    const bool last = (i == 2);
    if (last != (comma == std::string::npos)) return std::nullopt;  // too few or too many parts
    const std::optional<float> x = parse_float(text.substr(start, comma - start));
    if (!x) return std::nullopt;
    v[i] = *x;
    start = comma + 1;
  }
  return v;
}

std::string check_integer_in(const std::string& text, long long lo, long long hi) {
  const std::optional<long long> v = parse_integer(text);
  if (v && *v >= lo && *v <= hi) return "";
  return "must be an integer from " + std::to_string(lo) + " to " + std::to_string(hi) + ", got '" +
         text + "'";
}

std::string check_finite(const std::string& text) {
  if (parse_finite(text)) return "";
  return "must be a finite number, got '" + text + "'";
}

std::string check_vec3(const std::string& text) {
  if (parse_vec3(text)) return "";
  return "must be three finite numbers X,Y,Z, got '" + text + "'";
}

std::string check_distance(const std::string& text) {
  const std::optional<float> d = parse_float(text);
  if (d && *d > 0.0f) return "";
  return "must be a finite number greater than 0, got '" + text + "'";
}

std::string format_double(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, ec == std::errc() ? end : buffer);
}

std::string format_float(float value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  std::string text(buffer, ec == std::errc() ? end : buffer);
  // The float's shortest form is exact when parsed as a float; parse_float reads a double and
  // rounds that, and double rounding could in principle land on the other float. The double's own
  // shortest form converts back to the exact double and then exactly to `value`.
  const std::optional<float> back = parse_float(text);
  // Compared as bits, so that -0 must come back as -0 and not as the equal-comparing +0.
  if (back && std::bit_cast<uint32_t>(*back) == std::bit_cast<uint32_t>(value)) return text;
  return format_double(static_cast<double>(value));
}

std::string format_vec3(glm::vec3 value) {
  return format_float(value.x) + "," + format_float(value.y) + "," + format_float(value.z);
}

std::string kernel_list() {
  std::string names;
  for (Kernel k : kAllKernels) {
    if (!names.empty()) names += "|";
    names += kernel_name(k);
  }
  return names;
}

std::string accel_list() {
  std::string names;
  for (AccelKind k : available_accels()) {
    if (!names.empty()) names += "|";
    names += accel_name(k);
  }
  return names;
}

std::string check_builtin_scene(const std::string& name) {
  if (is_builtin_scene(name)) return "";
  return "unknown scene '" + name + "' (use " + std::string(kBuiltinSceneHelp) + ")";
}

std::string check_accel(const std::string& name) {
  const std::optional<AccelKind> kind = parse_accel(name);
  if (kind && accel_available(*kind)) return "";
  if (kind) return "'" + name + "' is not built in (this build has " + accel_list() + ")";
  return "unknown acceleration structure '" + name + "' (use " + accel_list() + ")";
}

std::string check_bvh_build(const std::string& name) {
  if (parse_bvh_build(name)) return "";
  return "unknown BVH build '" + name + "' (use sah or morton)";
}

std::string check_kernel(const std::string& name) {
  if (parse_kernel(name)) return "";
  return "unknown kernel '" + name + "' (use " + kernel_list() + ")";
}

}  // namespace tritrace
