// Parameter lists of pbrt-v4 directives and the reduction of its spectra to linear RGB (tritrace
// renders in RGB; docs/SCENE_FORMAT.md lists what each spectrum form becomes).
#include "tritrace/scene/io/pbrt_params.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <utility>

#include "tritrace/error.h"

namespace tritrace {
namespace {

[[noreturn]] void fail(const PbrtLocation& at, const std::string& reason) {
  throw Error(at.describe(), reason);
}

std::string declared(const PbrtParam& p) {
  return "\"" + p.type + " " + p.name + "\"";
}

bool is_string_type(std::string_view type) {
  return type == "string" || type == "texture" || type == "bool";
}

// A number token in the forms pbrt accepts (C's strtod without hex or inf/nan), or nullopt.
std::optional<double> parse_number(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const char* begin = text.data();
  const char* end = text.data() + text.size();
  if (*begin == '+') ++begin;
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(begin, end, value, std::chars_format::general);
  if (ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

// The declaration's type, with pbrt's older spellings folded into pbrt-v4's.
std::string canonical_type(const std::string& type) {
  if (type == "point") return "point3";
  if (type == "vector") return "vector3";
  if (type == "normal3") return "normal";
  if (type == "color") return "rgb";
  return type;
}

constexpr std::string_view kTypes[] = {"float",   "integer",  "string",   "bool",    "rgb",
                                       "point2",  "vector2",  "point3",   "vector3", "normal",
                                       "texture", "spectrum", "blackbody"};

// Piecewise-linear interpolation of (wavelength, value) pairs at `lambda`, constant beyond the
// ends.
double sampled_at(const std::vector<double>& pairs, double lambda) {
  const size_t n = pairs.size() / 2;
  if (lambda <= pairs[0]) return pairs[1];
  for (size_t i = 1; i < n; ++i) {
    const double l0 = pairs[2 * i - 2], l1 = pairs[2 * i];
    if (lambda <= l1) {
      const double t = l1 > l0 ? (lambda - l0) / (l1 - l0) : 1.0;
      return pairs[2 * i - 1] + t * (pairs[2 * i + 1] - pairs[2 * i - 1]);
    }
  }
  return pairs[2 * n - 1];
}

// One lobe of Wyman, Sloan and Shirley's fit of the CIE 1931 matching functions ("Simple Analytic
// Approximations to the CIE XYZ Color Matching Functions", JCGT 2013, section 2.1).
double lobe(double x, double mu, double below, double above) {
  const double t = (x - mu) / (x < mu ? below : above);
  return std::exp(-0.5 * t * t);
}

}  // namespace

const PbrtParam* PbrtParams::find(std::string_view name) const {
  for (const PbrtParam& p : list) {
    if (p.name == name) {
      p.used = true;
      return &p;
    }
  }
  return nullptr;
}

double PbrtParams::get_float(std::string_view name, double fallback) const {
  const PbrtParam* p = find(name);
  if (!p) return fallback;
  if (p->type != "float" && p->type != "integer") fail(p->at, declared(*p) + " must be a float");
  if (p->numbers.size() != 1) fail(p->at, declared(*p) + " takes one value");
  return p->numbers[0];
}

int PbrtParams::get_int(std::string_view name, int fallback) const {
  const PbrtParam* p = find(name);
  if (!p) return fallback;
  if (p->type != "integer") fail(p->at, declared(*p) + " must be an integer");
  if (p->numbers.size() != 1) fail(p->at, declared(*p) + " takes one value");
  return static_cast<int>(p->numbers[0]);
}

std::vector<int> PbrtParams::get_ints(std::string_view name) const {
  const PbrtParam* p = find(name);
  if (!p) return {};
  if (p->type != "integer") fail(p->at, declared(*p) + " must be an integer list");
  std::vector<int> out;
  out.reserve(p->numbers.size());
  for (double v : p->numbers) out.push_back(static_cast<int>(v));
  return out;
}

std::string PbrtParams::get_string(std::string_view name, const std::string& fallback) const {
  const PbrtParam* p = find(name);
  if (!p) return fallback;
  if (p->type != "string") fail(p->at, declared(*p) + " must be a string");
  if (p->strings.size() != 1) fail(p->at, declared(*p) + " takes one value");
  return p->strings[0];
}

bool PbrtParams::get_bool(std::string_view name, bool fallback) const {
  const PbrtParam* p = find(name);
  if (!p) return fallback;
  if (p->type != "bool") fail(p->at, declared(*p) + " must be a bool");
  if (p->strings.size() != 1) fail(p->at, declared(*p) + " takes one value");
  return p->strings[0] == "true";
}

std::optional<glm::dvec3> PbrtParams::get_point(std::string_view name) const {
  const PbrtParam* p = find(name);
  if (!p) return std::nullopt;
  if (p->type != "point3" && p->type != "vector3" && p->type != "normal") {
    fail(p->at, declared(*p) + " must be a point3");
  }
  if (p->numbers.size() != 3) fail(p->at, declared(*p) + " takes three values");
  return glm::dvec3(p->numbers[0], p->numbers[1], p->numbers[2]);
}

const std::vector<double>* PbrtParams::get_numbers(
    std::string_view name, std::initializer_list<std::string_view> types) const {
  const PbrtParam* p = find(name);
  if (!p) return nullptr;
  if (std::find(types.begin(), types.end(), p->type) == types.end()) {
    fail(p->at,
         declared(*p) + " has the wrong type (expected " + std::string(*types.begin()) + ")");
  }
  return &p->numbers;
}

std::string PbrtParams::texture_name(std::string_view name) const {
  for (const PbrtParam& p : list) {
    if (p.name == name && p.type == "texture") {
      p.used = true;
      if (p.strings.size() != 1) fail(p.at, declared(p) + " takes one texture name");
      return p.strings[0];
    }
  }
  return {};
}

std::optional<double> PbrtParams::get_float_or_texture(std::string_view name,
                                                       std::string* texture) const {
  const std::string t = texture_name(name);
  if (!t.empty()) {
    if (texture) *texture = t;
    return std::nullopt;
  }
  const PbrtParam* p = find(name);
  if (!p) return std::nullopt;
  return get_float(name, 0.0);
}

std::optional<glm::vec3> PbrtParams::get_rgb(std::string_view name) const {
  const PbrtParam* p = nullptr;
  for (const PbrtParam& q : list) {
    if (q.name == name && q.type != "texture") p = &q;
  }
  if (!p) return std::nullopt;
  p->used = true;
  const auto& v = p->numbers;
  if (p->type == "rgb") {
    if (v.size() != 3) fail(p->at, declared(*p) + " takes three values");
    return glm::vec3(glm::dvec3(v[0], v[1], v[2]));
  }
  if (p->type == "blackbody") {
    // pbrt-v3's form [temperature scale], which assimp's pbrt exporter still writes, is read with
    // pbrt-v3's meaning: the normalised blackbody times the scale.
    if (v.empty() || v.size() > 2 || !(v[0] > 0.0) || (v.size() == 2 && !(v[1] >= 0.0))) {
      fail(p->at, declared(*p) +
                      " takes one positive temperature in kelvin (or pbrt-v3's temperature and "
                      "scale)");
    }
    const glm::vec3 rgb = blackbody_rgb(v[0]);
    return v.size() == 2 ? rgb * static_cast<float>(v[1]) : rgb;
  }
  if (p->type == "float" && v.size() == 1) return glm::vec3(static_cast<float>(v[0]));
  if (p->type != "spectrum") fail(p->at, declared(*p) + " must be an rgb or a spectrum");
  if (!p->strings.empty()) {
    if (p->strings.size() != 1) fail(p->at, declared(*p) + " takes one named spectrum");
    if (auto rgb = named_spectrum_rgb(p->strings[0])) return rgb;
    fail(p->at, declared(*p) + ": unknown named spectrum \"" + p->strings[0] +
                    "\" (spectrum files are not read; give an rgb)");
  }
  if (v.size() == 1) return glm::vec3(static_cast<float>(v[0]));
  if (v.size() < 2 || v.size() % 2 != 0) {
    fail(p->at, declared(*p) + " takes wavelength / value pairs");
  }
  for (size_t i = 2; i < v.size(); i += 2) {
    if (!(v[i] > v[i - 2])) fail(p->at, declared(*p) + ": wavelengths must increase");
  }
  // The spectrum at the wavelengths that red, green and blue are most alike to (an approximation:
  // pbrt integrates the spectrum against the film's matching functions).
  return glm::vec3(static_cast<float>(sampled_at(v, 610.0)),
                   static_cast<float>(sampled_at(v, 550.0)),
                   static_cast<float>(sampled_at(v, 465.0)));
}

std::vector<const PbrtParam*> PbrtParams::unused() const {
  std::vector<const PbrtParam*> out;
  for (const PbrtParam& p : list) {
    if (!p.used) out.push_back(&p);
  }
  return out;
}

PbrtParams parse_pbrt_params(PbrtTokenizer& tokens) {
  PbrtParams params;
  while (tokens.peek() && tokens.peek()->kind == PbrtToken::Kind::kString) {
    const PbrtToken decl = *tokens.next();
    PbrtParam p;
    p.at = decl.at;
    // "type name": two words separated by whitespace.
    const std::string& d = decl.text;
    const size_t a = d.find_first_not_of(" \t");
    const size_t b = a == std::string::npos ? a : d.find_first_of(" \t", a);
    const size_t c = b == std::string::npos ? b : d.find_first_not_of(" \t", b);
    const size_t e = c == std::string::npos ? c : d.find_first_of(" \t", c);
    if (c == std::string::npos ||
        (e != std::string::npos && d.find_first_not_of(" \t", e) != std::string::npos)) {
      fail(decl.at, "expected a parameter declaration \"type name\", got " + shown_token(decl));
    }
    p.type = canonical_type(d.substr(a, b - a));
    p.name = d.substr(c, e == std::string::npos ? std::string::npos : e - c);
    if (std::find(std::begin(kTypes), std::end(kTypes), p.type) == std::end(kTypes)) {
      fail(decl.at, "unknown parameter type \"" + p.type + "\" in " + shown_token(decl));
    }
    std::optional<PbrtToken> t = tokens.next();
    if (!t)
      fail(tokens.end_location(), "unexpected end of file: " + declared(p) + " needs a value");
    std::vector<PbrtToken> values;
    if (t->kind == PbrtToken::Kind::kOpen) {
      while (true) {
        std::optional<PbrtToken> v = tokens.next();
        if (!v) fail(t->at, "unterminated '[' (no matching ']' before the end of the file)");
        if (v->kind == PbrtToken::Kind::kClose) break;
        if (v->kind == PbrtToken::Kind::kOpen) fail(v->at, "unexpected '[' inside a value list");
        values.push_back(std::move(*v));
      }
    } else if (t->kind == PbrtToken::Kind::kClose) {
      fail(t->at, "unexpected ']'");
    } else {
      values.push_back(std::move(*t));
    }
    // "spectrum" takes numbers or one name; everything else one kind only.
    const bool strings = is_string_type(p.type) || (p.type == "spectrum" && !values.empty() &&
                                                    values[0].kind == PbrtToken::Kind::kString);
    for (const PbrtToken& v : values) {
      if (p.type == "bool") {
        if (v.text != "true" && v.text != "false") {
          fail(v.at, declared(p) + ": expected true or false, got " + shown_token(v));
        }
        p.strings.push_back(v.text);
      } else if (strings) {
        if (v.kind != PbrtToken::Kind::kString) {
          fail(v.at, declared(p) + ": expected a quoted string, got " + shown_token(v));
        }
        p.strings.push_back(v.text);
      } else {
        const std::optional<double> x =
            v.kind == PbrtToken::Kind::kWord ? parse_number(v.text) : std::nullopt;
        if (!x) fail(v.at, declared(p) + ": expected a number, got " + shown_token(v));
        // Values must fit what they become: an int, or a float (tritrace renders in floats).
        if (p.type == "integer" && !(*x == std::floor(*x) && std::abs(*x) <= 2147483647.0)) {
          fail(v.at, declared(p) + ": expected an integer, got " + shown_token(v));
        }
        if (std::abs(*x) > 3.4e38) {
          fail(v.at, declared(p) + ": " + shown_token(v) + " is beyond float range");
        }
        p.numbers.push_back(*x);
      }
    }
    if (values.empty()) fail(t->at, declared(p) + " has no values");
    params.list.push_back(std::move(p));
  }
  return params;
}

std::optional<glm::vec3> named_spectrum_rgb(std::string_view name) {
  // Metals: RGB reductions of measured complex indices (n, k) of the pure metals
  // (refractiveindex.info data, averaged over the bands of the sRGB primaries), approximations of
  // pbrt-v4's tables.
  struct Named {
    std::string_view name;
    glm::vec3 rgb;
  };
  static constexpr Named kNamed[] = {
      {"metal-Ag-eta", {0.155265f, 0.116723f, 0.138342f}},
      {"metal-Ag-k", {4.82835f, 3.12225f, 2.14696f}},
      {"metal-Al-eta", {1.65746f, 0.880369f, 0.521229f}},
      {"metal-Al-k", {9.22387f, 6.26952f, 4.837f}},
      {"metal-Au-eta", {0.143119f, 0.374957f, 1.44248f}},
      {"metal-Au-k", {3.98316f, 2.38572f, 1.60322f}},
      {"metal-Cu-eta", {0.200438f, 0.924033f, 1.10221f}},
      {"metal-Cu-k", {3.91295f, 2.45285f, 2.14219f}},
      {"metal-CuZn-eta", {0.444f, 0.527f, 1.094f}},
      {"metal-CuZn-k", {3.695f, 2.765f, 1.829f}},
      {"metal-MgO-eta", {1.732f, 1.738f, 1.750f}},
      {"metal-MgO-k", {0.0f, 0.0f, 0.0f}},
      {"metal-TiO2-eta", {2.58f, 2.65f, 2.80f}},
      {"metal-TiO2-k", {0.0f, 0.0f, 0.0f}},
      // Glasses: the index at the helium d line (587.6 nm) from Schott's catalogue; pbrt's
      // glass-F5/F10/F11 are the SF5/SF10/SF11 flints.
      {"glass-BK7", glm::vec3(1.5168f)},
      {"glass-BAF10", glm::vec3(1.6700f)},
      {"glass-FK51A", glm::vec3(1.4866f)},
      {"glass-LASF9", glm::vec3(1.8503f)},
      {"glass-F5", glm::vec3(1.6727f)},
      {"glass-F10", glm::vec3(1.7283f)},
      {"glass-F11", glm::vec3(1.7847f)},
      // Illuminants, normalised to luminance 1 as pbrt-v4 normalises light spectra: D65 is the
      // sRGB white point; A is a 2856 K blackbody by definition.
      {"stdillum-D65", glm::vec3(1.0f)},
  };
  for (const Named& n : kNamed) {
    if (n.name == name) return n.rgb;
  }
  if (name == "stdillum-A") return blackbody_rgb(2856.0);
  return std::nullopt;
}

glm::vec3 blackbody_rgb(double kelvin) {
  // Planck's law times the fitted matching functions, summed over 360-830 nm in 1 nm steps.
  constexpr double c = 299792458.0, h = 6.62606957e-34, kb = 1.3806488e-23;
  double x = 0.0, y = 0.0, z = 0.0;
  for (int l = 360; l <= 830; ++l) {
    const double nm = l;
    const double m = nm * 1e-9;
    const double planck =
        (2.0 * h * c * c) / (std::pow(m, 5) * (std::exp(h * c / (m * kb * kelvin)) - 1.0));
    if (!std::isfinite(planck)) continue;
    x += planck * (1.056 * lobe(nm, 599.8, 37.9, 31.0) + 0.362 * lobe(nm, 442.0, 16.0, 26.7) -
                   0.065 * lobe(nm, 501.1, 20.4, 26.2));
    y += planck * (0.821 * lobe(nm, 568.8, 46.9, 40.5) + 0.286 * lobe(nm, 530.9, 16.3, 31.1));
    z += planck * (1.217 * lobe(nm, 437.0, 11.8, 36.0) + 0.681 * lobe(nm, 459.0, 26.0, 13.8));
  }
  if (!(y > 0.0)) return glm::vec3(0.0f);
  x /= y;
  z /= y;
  y = 1.0;
  // XYZ to linear sRGB (IEC 61966-2-1).
  const double r = 3.2406 * x - 1.5372 * y - 0.4986 * z;
  const double g = -0.9689 * x + 1.8758 * y + 0.0415 * z;
  const double b = 0.0557 * x - 0.2040 * y + 1.0570 * z;
  return glm::vec3(static_cast<float>(std::max(r, 0.0)), static_cast<float>(std::max(g, 0.0)),
                   static_cast<float>(std::max(b, 0.0)));
}

}  // namespace tritrace
