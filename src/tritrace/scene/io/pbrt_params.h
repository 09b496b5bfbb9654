// pbrt-v4 parameter lists ("float fov" [45] "rgb reflectance" [.5 .5 .5] ...): parsed from tokens,
// looked up by name with type and count checks that name the file, line and column, and spectra
// (rgb, named, sampled, blackbody) reduced to the linear RGB that tritrace renders with.
#pragma once

#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "tritrace/scene/io/pbrt_tokenizer.h"

namespace tritrace {

struct PbrtParam {
  std::string type;  // as written: "float", "integer", "rgb", "spectrum", "texture" ...
  std::string name;
  std::vector<double> numbers;       // numeric values
  std::vector<std::string> strings;  // string values ("true"/"false" for bools)
  PbrtLocation at;                   // where the "type name" string is
  mutable bool used = false;         // looked up by the mapping (the rest are warned about)
};

class PbrtParams {
 public:
  std::vector<PbrtParam> list;

  // The parameter named `name`, marked used, or null.
  const PbrtParam* find(std::string_view name) const;

  // Typed single values with defaults; a parameter of the wrong type or count is an Error at its
  // location.
  double get_float(std::string_view name, double fallback) const;
  int get_int(std::string_view name, int fallback) const;
  std::string get_string(std::string_view name, const std::string& fallback) const;
  bool get_bool(std::string_view name, bool fallback) const;
  std::optional<glm::dvec3> get_point(std::string_view name) const;  // point3/vector3/normal
  // All numbers of a parameter of one of the given types (e.g. "point3 P"), empty when absent.
  const std::vector<double>* get_numbers(std::string_view name,
                                         std::initializer_list<std::string_view> types) const;
  std::vector<int> get_ints(std::string_view name) const;

  // A colour: "rgb"/"color" values, a "spectrum" (a named spectrum, one constant, or wavelength /
  // value pairs), a "blackbody" temperature (luminance 1, as pbrt-v4 normalises light spectra)
  // or one "float"; nullopt when absent or given as a "texture" (see texture_name).
  std::optional<glm::vec3> get_rgb(std::string_view name) const;
  // The texture a parameter names ("texture reflectance" "checks"), or empty.
  std::string texture_name(std::string_view name) const;
  // A float that may be given as a value or as a named float texture: the value, or nullopt.
  std::optional<double> get_float_or_texture(std::string_view name, std::string* texture) const;

  // Parameters nobody looked up, for warnings.
  std::vector<const PbrtParam*> unused() const;
};

// Reads "type name" value pairs while the next token is a string. Throws Error("FILE:LINE:COL",
// reason) for a malformed declaration, an unterminated '[' or a value of the wrong kind.
PbrtParams parse_pbrt_params(PbrtTokenizer& tokens);

// pbrt-v4's named spectra reduced to RGB: metals' complex index ("metal-Au-eta", "metal-Au-k")
// and glasses' index of refraction ("glass-BK7", as a grey triple of its index at the d line).
std::optional<glm::vec3> named_spectrum_rgb(std::string_view name);

// The linear sRGB colour of a blackbody at `kelvin`, scaled to luminance (Y) 1: what pbrt-v4's
// normalised blackbody light spectrum looks like on an RGB film. Negative channels clamp to 0.
glm::vec3 blackbody_rgb(double kelvin);

}  // namespace tritrace
