// The scene file parser: nlohmann-json reads the text, then one pass over the document checks
// every key against the format's tables and converts values, naming the JSON location of any error.
#include "tritrace/scene/io/scene_file.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>

#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/io/input_file.h"
#include "tritrace/scene/io/transform.h"
#include "tritrace/scene/io/triangle_filter.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

constexpr size_t kMaxShownChars = 60;
// Indices of refraction beyond any real material's (diamond 2.4, germanium 4) or their inverse.
constexpr float kMaxIor = 10.0f;

// A user's string made safe for a one-line message: control characters become '?', long text is
// cut.
std::string shown(std::string_view s) {
  std::string out;
  for (char c : s.substr(0, kMaxShownChars)) {
    out += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  }
  if (s.size() > kMaxShownChars) out += "...";
  return out;
}

std::string describe(const Json& j) {
  if (j.is_number() || j.is_boolean() || j.is_null()) return shown(j.dump());
  if (j.is_string()) return "'" + shown(j.get_ref<const std::string&>()) + "'";
  return std::string("an ") + (j.is_object() ? "object" : "array");
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Line and column (1-based) of byte offset `pos` in `text`.
std::string line_column(std::string_view text, size_t pos) {
  pos = std::min(pos, text.size());
  const size_t line = 1 + std::count(text.begin(), text.begin() + pos, '\n');
  const size_t last_newline = text.substr(0, pos).rfind('\n');
  const size_t column = pos - (last_newline == std::string_view::npos ? 0 : last_newline + 1) + 1;
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

Json parse_text(std::string_view text, const std::string& path) {
  try {
    return Json::parse(text, nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const Json::parse_error& e) {
    // nlohmann's message: "[json.exception.parse_error.101] parse error at line L, column C: why".
    std::string what = e.what();
    const size_t at = what.find(" at line ");
    const size_t colon = what.find(": ", at == std::string::npos ? 0 : at);
    std::string why = colon == std::string::npos ? what : what.substr(colon + 2);
    if (why.rfind("syntax error while parsing ", 0) == 0) why = why.substr(27);
    const size_t pos = e.byte > 0 ? e.byte - 1 : 0;
    throw Error(path, "invalid JSON at " + line_column(text, pos) + ": " + shown(why));
  } catch (const Json::out_of_range& e) {
    // Number overflow (id 406) carries no position; the message quotes the number, so find it.
    std::string what = e.what();
    const size_t q1 = what.find('\'');
    const size_t q2 = what.rfind('\'');
    if (q1 != std::string::npos && q2 > q1) {
      const std::string number = what.substr(q1 + 1, q2 - q1 - 1);
      const size_t pos = text.find(number);
      if (pos != std::string_view::npos) {
        throw Error(path, "invalid JSON at " + line_column(text, pos) + ": number " +
                              shown(number) + " is out of range");
      }
    }
    throw Error(path, "invalid JSON: number out of range");
  } catch (const Json::exception& e) {
    throw Error(path, std::string("invalid JSON: ") + shown(e.what()));
  }
}

glm::mat3 rotation_xyz_degrees(glm::vec3 degrees) {
  const glm::vec3 r = degrees * static_cast<float>(std::numbers::pi / 180.0);
  const float cx = std::cos(r.x), sx = std::sin(r.x);
  const float cy = std::cos(r.y), sy = std::sin(r.y);
  const float cz = std::cos(r.z), sz = std::sin(r.z);
  // Column-major (glm): rotate about x first, then y, then z: R = Rz * Ry * Rx.
  const glm::mat3 rx(1, 0, 0, 0, cx, sx, 0, -sx, cx);
  const glm::mat3 ry(cy, 0, -sy, 0, 1, 0, sy, 0, cy);
  const glm::mat3 rz(cz, sz, 0, -sz, cz, 0, 0, 0, 1);
  return rz * ry * rx;
}

class Parser {
 public:
  Parser(std::string_view text, const std::string& path, const SceneFileOptions& options)
      : text_(text), path_(path), options_(options) {}

  LoadedScene run() {
    const Json doc = parse_text(text_, path_);
    if (!doc.is_object()) fail("", "a scene must be a JSON object, got " + describe(doc));
    check_keys(doc, "",
               {"description", "camera", "lights", "ambient", "environment", "materials", "meshes",
                "output", "integrator"});
    if (doc.contains("description") && !doc["description"].is_string()) {
      fail("/description", "must be a string, got " + describe(doc["description"]));
    }
    out_.scene.ambient = kLabAmbient;
    if (doc.contains("camera")) parse_camera(doc["camera"]);
    if (doc.contains("lights")) parse_lights(doc["lights"]);
    if (doc.contains("ambient")) {
      out_.scene.ambient = non_negative_vec3(doc["ambient"], "/ambient");
    }
    if (doc.contains("environment")) parse_environment(doc["environment"]);
    if (doc.contains("materials")) parse_materials(doc["materials"]);
    if (!doc.contains("meshes")) fail("", "no geometry: the scene has no \"meshes\"");
    parse_meshes(doc["meshes"]);
    if (doc.contains("output")) parse_output(doc["output"]);
    if (doc.contains("integrator")) parse_integrator(doc["integrator"]);
    return std::move(out_);
  }

 private:
  [[noreturn]] void fail(const std::string& where, const std::string& reason) const {
    throw Error(path_, where.empty() ? reason : where + ": " + reason);
  }

  [[noreturn]] void fail_too_many_triangles(const std::string& where) const {
    fail(where, "the scene has more than " + std::to_string(kMaxSceneTriangles) + " triangles");
  }

  const Json& object(const Json& j, const std::string& where) const {
    if (!j.is_object()) fail(where, "must be an object, got " + describe(j));
    return j;
  }
  const Json& array(const Json& j, const std::string& where) const {
    if (!j.is_array()) fail(where, "must be an array, got " + describe(j));
    return j;
  }

  // Every key must be known; an unknown one is reported with the nearest known key.
  void check_keys(const Json& obj, const std::string& where,
                  std::initializer_list<std::string_view> known) const {
    for (const auto& [key, value] : obj.items()) {
      if (std::find(known.begin(), known.end(), key) != known.end()) continue;
      std::string_view best;
      size_t best_distance = std::numeric_limits<size_t>::max();
      for (std::string_view k : known) {
        const size_t d = edit_distance(lower(key), k);
        if (d < best_distance) best_distance = d, best = k;
      }
      fail(where.empty() ? "/" : where,
           "unknown key '" + shown(key) + "' (did you mean '" + std::string(best) + "'?)");
    }
  }

  double number(const Json& j, const std::string& where) const {
    if (!j.is_number()) fail(where, "must be a number, got " + describe(j));
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(where, "must be finite, got " + describe(j));
    return v;
  }

  float single(const Json& j, const std::string& where) const {
    const double v = number(j, where);
    if (std::abs(v) > std::numeric_limits<float>::max()) {
      fail(where, "is out of range for a 32-bit float, got " + describe(j));
    }
    return static_cast<float>(v);
  }

  long long integer_in(const Json& j, const std::string& where, long long lo, long long hi) const {
    const std::string rule =
        "must be an integer from " + std::to_string(lo) + " to " + std::to_string(hi);
    if (j.is_number_unsigned()) {
      const auto v = j.get<uint64_t>();
      if (v <= static_cast<uint64_t>(hi) && static_cast<long long>(v) >= lo) {
        return static_cast<long long>(v);
      }
    } else if (j.is_number_integer()) {
      const auto v = j.get<int64_t>();
      if (v >= lo && v <= hi) return v;
    }
    fail(where, rule + ", got " + describe(j));
  }

  glm::vec3 vec3(const Json& j, const std::string& where) const {
    if (!j.is_array() || j.size() != 3) {
      fail(where, "must be an array of 3 numbers, got " +
                      (j.is_array() ? std::to_string(j.size()) + " elements" : describe(j)));
    }
    return {single(j[0], where + "/0"), single(j[1], where + "/1"), single(j[2], where + "/2")};
  }

  glm::vec3 non_negative_vec3(const Json& j, const std::string& where) const {
    const glm::vec3 v = vec3(j, where);
    for (int i = 0; i < 3; ++i) {
      if (v[i] < 0.0f) fail(where + "/" + std::to_string(i), "must not be negative");
    }
    return v;
  }

  // A direction: three numbers, not all zero, returned normalised.
  glm::vec3 unit_vec3(const Json& j, const std::string& where) const {
    const glm::dvec3 v(vec3(j, where));
    const double len = glm::length(v);
    if (!(len > 0.0) || !std::isfinite(len)) fail(where, "must be a non-zero direction");
    return glm::vec3(v / len);
  }

  // {"color": [r, g, b]} or {"file": "sky.hdr" | "sky.exr", "scale": s, "rotate": degrees}.
  void parse_environment(const Json& j) {
    const Json& env = object(j, "/environment");
    check_keys(env, "/environment", {"color", "file", "scale", "rotate"});
    const bool has_file = env.contains("file");
    if (env.contains("color") && has_file) {
      fail("/environment", "has both \"color\" and \"file\"; give one");
    }
    if (!env.contains("color") && !has_file) fail("/environment", "missing \"color\" or \"file\"");
    if (!has_file) {
      for (const char* key : {"scale", "rotate"}) {
        if (env.contains(key))
          fail("/environment/" + std::string(key), "applies to a \"file\" only");
      }
      out_.scene.environment = non_negative_vec3(env["color"], "/environment/color");
      return;
    }
    auto map = std::make_shared<EnvironmentMap>();
    if (env.contains("scale")) {
      map->scale = single(env["scale"], "/environment/scale");
      if (map->scale < 0.0f)
        fail("/environment/scale", "must not be negative, got " + describe(env["scale"]));
    }
    if (env.contains("rotate")) map->rotate_degrees = single(env["rotate"], "/environment/rotate");
    const std::string name = string(env["file"], "/environment/file");
    if (name.empty()) fail("/environment/file", "must name an image file");
    const fs::path resolved =
        fs::path(name).is_absolute() ? fs::path(name) : fs::path(path_).parent_path() / name;
    Image image;
    try {
      image = read_image_float(resolved.string());
    } catch (const Error& e) {
      fail("/environment/file", "'" + shown(name) + "': " + e.reason());
    }
    map->width = image.width();
    map->height = image.height();
    map->texels = image.pixels();
    map->path = resolved.string();
    out_.scene.environment_map = std::move(map);
  }

  float unit(const Json& j, const std::string& where) const {
    const float v = single(j, where);
    if (!(v >= 0.0f && v <= 1.0f)) fail(where, "must be from 0 to 1, got " + describe(j));
    return v;
  }

  MaterialType material_type(const Json& j, const std::string& where) const {
    const std::string t = string(j, where);
    if (t == "diffuse") return MaterialType::kDiffuse;
    if (t == "conductor") return MaterialType::kConductor;
    if (t == "dielectric") return MaterialType::kDielectric;
    if (t == "principled") return MaterialType::kPrincipled;
    fail(where, "unknown material type '" + shown(t) +
                    "' (use diffuse, conductor, dielectric or principled)");
  }

  std::string string(const Json& j, const std::string& where) const {
    if (!j.is_string()) fail(where, "must be a string, got " + describe(j));
    return j.get<std::string>();
  }

  void parse_camera(const Json& j) {
    object(j, "/camera");
    check_keys(j, "/camera",
               {"position", "look_at", "up", "vertical_fov", "focal_length", "width", "height",
                "aperture_radius", "focus_distance"});
    CameraSpec& c = out_.camera;
    if (j.contains("width"))
      c.width = static_cast<int>(integer_in(j["width"], "/camera/width", 1, kMaxImageSide));
    if (j.contains("height")) {
      c.height = static_cast<int>(integer_in(j["height"], "/camera/height", 1, kMaxImageSide));
    }
    if (j.contains("position")) c.position = vec3(j["position"], "/camera/position");
    if (j.contains("look_at")) c.look_at = vec3(j["look_at"], "/camera/look_at");
    if (j.contains("up")) c.up = vec3(j["up"], "/camera/up");
    if (j.contains("vertical_fov") && j.contains("focal_length")) {
      fail("/camera", "give either \"vertical_fov\" or \"focal_length\", not both");
    }
    if (j.contains("vertical_fov")) {
      const double fov = number(j["vertical_fov"], "/camera/vertical_fov");
      if (!(fov > 0.0 && fov < 180.0)) {
        fail("/camera/vertical_fov",
             "must be between 0 and 180 degrees (exclusive), got " + describe(j["vertical_fov"]));
      }
      c.vertical_fov_degrees = fov;
    }
    if (j.contains("focal_length")) {
      const float f = single(j["focal_length"], "/camera/focal_length");
      if (!(f > 0.0f)) {
        fail("/camera/focal_length", "must be positive, got " + describe(j["focal_length"]));
      }
      c.focal_length_px = f;
    }
    if (j.contains("aperture_radius")) {
      const float r = single(j["aperture_radius"], "/camera/aperture_radius");
      if (!(r >= 0.0f)) {
        fail("/camera/aperture_radius",
             "must be at least 0 (0: a pinhole), got " + describe(j["aperture_radius"]));
      }
      c.aperture_radius = r;
    }
    if (j.contains("focus_distance")) {
      const float d = single(j["focus_distance"], "/camera/focus_distance");
      if (!(d > 0.0f)) {
        fail("/camera/focus_distance", "must be positive, got " + describe(j["focus_distance"]));
      }
      c.focus_distance = d;
    }
    if (!Camera::is_valid_look_at(c.position, c.look_at, c.up)) {
      fail("/camera",
           "position and look_at must differ, and up must not be parallel to the "
           "viewing direction");
    }
  }

  // {"type": "point" (the default), "position", "power"}, {"type": "spot", "position",
  // "direction", "intensity", "outer_angle", "inner_angle" (0 by default)} or {"type":
  // "directional", "direction", "irradiance"}; angles in degrees from the axis.
  void parse_lights(const Json& j) {
    array(j, "/lights");
    for (size_t i = 0; i < j.size(); ++i) {
      const std::string where = "/lights/" + std::to_string(i);
      const Json& l = object(j[i], where);
      std::string type = "point";
      if (l.contains("type")) type = string(l["type"], where + "/type");
      const auto require = [&](std::initializer_list<const char*> keys) {
        for (const char* key : keys) {
          if (!l.contains(key)) fail(where, std::string("missing \"") + key + "\"");
        }
      };
      if (type == "point") {
        check_keys(l, where, {"type", "position", "power"});
        require({"position", "power"});
        out_.scene.lights.push_back({vec3(l["position"], where + "/position"),
                                     non_negative_vec3(l["power"], where + "/power")});
      } else if (type == "spot") {
        check_keys(l, where,
                   {"type", "position", "direction", "intensity", "inner_angle", "outer_angle"});
        require({"position", "direction", "intensity", "outer_angle"});
        SpotLight s;
        s.position = vec3(l["position"], where + "/position");
        s.direction = unit_vec3(l["direction"], where + "/direction");
        s.intensity = non_negative_vec3(l["intensity"], where + "/intensity");
        const double outer = number(l["outer_angle"], where + "/outer_angle");
        if (!(outer > 0.0 && outer <= 180.0)) {
          fail(where + "/outer_angle",
               "must be more than 0 and at most 180 degrees, got " + describe(l["outer_angle"]));
        }
        double inner = 0.0;
        if (l.contains("inner_angle")) {
          inner = number(l["inner_angle"], where + "/inner_angle");
          if (!(inner >= 0.0 && inner < outer)) {
            fail(where + "/inner_angle", "must be at least 0 and less than outer_angle (" +
                                             describe(l["outer_angle"]) + ") degrees, got " +
                                             describe(l["inner_angle"]));
          }
        }
        s.cos_inner = static_cast<float>(std::cos(inner * std::numbers::pi / 180.0));
        s.cos_outer = static_cast<float>(std::cos(outer * std::numbers::pi / 180.0));
        if (!(s.cos_inner > s.cos_outer)) {
          fail(where + "/inner_angle", "is too close to outer_angle to tell their cosines apart");
        }
        s.falloff = SpotFalloff::kGltf;
        out_.scene.spot_lights.push_back(s);
      } else if (type == "directional") {
        check_keys(l, where, {"type", "direction", "irradiance"});
        require({"direction", "irradiance"});
        out_.scene.directional_lights.push_back(
            {unit_vec3(l["direction"], where + "/direction"),
             non_negative_vec3(l["irradiance"], where + "/irradiance")});
      } else {
        fail(where + "/type",
             "must be \"point\", \"spot\" or \"directional\", got '" + shown(type) + "'");
      }
    }
  }

  void parse_materials(const Json& j) {
    array(j, "/materials");
    for (size_t i = 0; i < j.size(); ++i) {
      const std::string where = "/materials/" + std::to_string(i);
      object(j[i], where);
      check_keys(j[i], where,
                 {"name", "type", "albedo", "emission", "two_sided", "roughness", "ior", "metallic",
                  "transmission", "eta", "k", "albedo_texture"});
      if (!j[i].contains("name")) fail(where, "missing \"name\"");
      const std::string name = string(j[i]["name"], where + "/name");
      if (name.empty()) fail(where + "/name", "must not be empty");
      Material m;
      if (j[i].contains("type")) m.type = material_type(j[i]["type"], where + "/type");
      // A dielectric's albedo tints what it transmits and is clear (1) by default; a conductor
      // takes its colour from albedo (F0) or from a complex index (eta and k); every other type
      // needs its colour.
      const bool complex_ior = j[i].contains("eta") || j[i].contains("k");
      if (complex_ior) {
        if (m.type != MaterialType::kConductor) {
          fail(where + "/" + (j[i].contains("eta") ? "eta" : "k"),
               "only conductor materials have it");
        }
        if (!j[i].contains("eta") || !j[i].contains("k")) {
          fail(where, std::string("missing \"") + (j[i].contains("eta") ? "k" : "eta") +
                          "\" (a complex index needs both eta and k)");
        }
        if (j[i].contains("albedo")) {
          fail(where + "/albedo", "a conductor takes albedo or eta and k, not both");
        }
        m.conductor_eta = non_negative_vec3(j[i]["eta"], where + "/eta");
        m.conductor_k = non_negative_vec3(j[i]["k"], where + "/k");
        for (int k = 0; k < 3; ++k) {
          const std::string at = std::to_string(k);
          if (!(m.conductor_eta[k] >= 0.01f && m.conductor_eta[k] <= kMaxIor)) {
            fail(where + "/eta/" + at, "must be from 0.01 to 10, got " + describe(j[i]["eta"][k]));
          }
          if (!(m.conductor_k[k] <= 100.0f)) {
            fail(where + "/k/" + at, "must be from 0 to 100, got " + describe(j[i]["k"][k]));
          }
        }
        // The reflectance at normal incidence, for what reads albedo (the lab integrator, AOVs).
        for (int k = 0; k < 3; ++k) {
          const float n = m.conductor_eta[k], kk = m.conductor_k[k];
          m.albedo[k] = ((n - 1) * (n - 1) + kk * kk) / ((n + 1) * (n + 1) + kk * kk);
        }
      } else if (m.type == MaterialType::kDielectric) {
        m.albedo = glm::vec3(1.0f);
      } else if (!j[i].contains("albedo")) {
        fail(where, "missing \"albedo\"");
      }
      if (j[i].contains("albedo")) {
        m.albedo = non_negative_vec3(j[i]["albedo"], where + "/albedo");
        for (int k = 0; k < 3; ++k) {
          if (m.albedo[k] > 1.0f) fail(where + "/albedo/" + std::to_string(k), "must be at most 1");
        }
      }
      const bool diffuse = m.type == MaterialType::kDiffuse;
      const bool principled = m.type == MaterialType::kPrincipled;
      const auto only_for = [&](const char* key, bool allowed, const char* types) {
        if (j[i].contains(key) && !allowed) {
          fail(where + "/" + key, std::string("only ") + types + " materials have it");
        }
      };
      only_for("roughness", !diffuse, "conductor, dielectric and principled");
      only_for("ior", m.type == MaterialType::kDielectric || principled,
               "dielectric and principled");
      only_for("metallic", principled, "principled");
      only_for("transmission", principled, "principled");
      if (j[i].contains("roughness")) m.roughness = unit(j[i]["roughness"], where + "/roughness");
      if (j[i].contains("metallic")) m.metallic = unit(j[i]["metallic"], where + "/metallic");
      if (j[i].contains("transmission")) {
        m.transmission = unit(j[i]["transmission"], where + "/transmission");
      }
      if (j[i].contains("ior")) {
        m.ior = single(j[i]["ior"], where + "/ior");
        if (!(m.ior >= 1.0f / kMaxIor && m.ior <= kMaxIor)) {
          fail(where + "/ior", "must be from 0.1 to 10, got " + describe(j[i]["ior"]));
        }
        if (!ior_supported(m.ior)) {
          fail(where + "/ior",
               "must be 1 or differ from 1 by at least 0.0001 (closer to 1, "
               "a rough surface's refraction is lost to float rounding), got " +
                   describe(j[i]["ior"]));
        }
      }
      if (j[i].contains("emission")) {
        m.emission = non_negative_vec3(j[i]["emission"], where + "/emission");
      }
      if (j[i].contains("two_sided")) {
        if (!j[i]["two_sided"].is_boolean()) {
          fail(where + "/two_sided", "must be true or false, got " + describe(j[i]["two_sided"]));
        }
        m.two_sided = j[i]["two_sided"].get<bool>();
      }
      if (j[i].contains("albedo_texture")) {
        m.albedo_texture.index = texture_file(j[i]["albedo_texture"], where + "/albedo_texture");
      }
      if (named_.count(name)) fail(where + "/name", "duplicate material '" + shown(name) + "'");
      named_[name] = add_material(m);
    }
  }

  // The index in scene.textures of an image file named relative to the scene file, read once
  // however many materials name it.
  int32_t texture_file(const Json& j, const std::string& where) {
    const std::string name = string(j, where);
    if (name.empty()) fail(where, "must name an image file");
    const fs::path resolved =
        fs::path(name).is_absolute() ? fs::path(name) : fs::path(path_).parent_path() / name;
    const std::string file = resolved.lexically_normal().string();
    if (const auto it = textures_.find(file); it != textures_.end()) return it->second;
    const std::string referenced = " (referenced by " + path_ + " at " + where + ")";
    try {
      const std::string bytes = read_input_file(file);
      const TextureImage image = decode_texture_image(
          std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), file);
      out_.scene.textures.push_back(Texture::from_srgb8(image));
    } catch (const Error& e) {
      throw Error(e.subject(), e.reason() + referenced, e.exit_code());
    }
    const auto index = static_cast<int32_t>(out_.scene.textures.size() - 1);
    textures_.emplace(file, index);
    return index;
  }

  uint32_t add_material(const Material& m) {
    out_.scene.materials.push_back(m);
    return static_cast<uint32_t>(out_.scene.materials.size() - 1);
  }

  uint32_t material_named(const Json& j, const std::string& where) const {
    const std::string name = string(j, where);
    const auto it = named_.find(name);
    if (it != named_.end()) return it->second;
    if (named_.empty()) fail(where, "unknown material '" + shown(name) + "' (none are defined)");
    std::string best;
    size_t best_distance = std::numeric_limits<size_t>::max();
    for (const auto& [known, id] : named_) {
      const size_t d = edit_distance(name, known);
      if (d < best_distance) best_distance = d, best = known;
    }
    fail(where, "unknown material '" + shown(name) + "' (did you mean '" + shown(best) + "'?)");
  }

  uint32_t default_material() {
    if (!default_material_) default_material_ = add_material({kNeutralGrey});
    return *default_material_;
  }

  std::optional<Transform> parse_transform(const Json& j, const std::string& where) const {
    object(j, where);
    check_keys(j, where, {"translate", "rotate", "scale"});
    Transform t;
    if (j.contains("translate")) t.translate = vec3(j["translate"], where + "/translate");
    if (j.contains("rotate")) t.rotate = rotation_xyz_degrees(vec3(j["rotate"], where + "/rotate"));
    if (j.contains("scale")) {
      const Json& s = j["scale"];
      t.scale = s.is_number() ? glm::vec3(single(s, where + "/scale")) : vec3(s, where + "/scale");
      for (int k = 0; k < 3; ++k) {
        if (t.scale[k] == 0.0f) fail(where + "/scale", "must not be zero");
      }
    }
    return t;
  }

  // Where the current mesh's triangles go: the scene's mesh, or a prototype when it has
  // "instances".
  TriangleMesh& target() { return target_ ? *target_ : out_.scene.mesh; }

  void add(glm::vec3 a, glm::vec3 b, glm::vec3 c, uint32_t material,
           const std::optional<Transform>& t, const std::string& where,
           const glm::vec3* normals = nullptr, const glm::vec2* uvs = nullptr) {
    if (stored_triangles_ >= kMaxSceneTriangles) {
      fail_too_many_triangles(where);
    }
    glm::vec3 moved[3];
    if (t) {
      a = t->apply(a);
      b = t->apply(b);
      c = t->apply(c);
      if (normals != nullptr) {
        for (int k = 0; k < 3; ++k) moved[k] = t->apply_normal(normals[k]);
        normals = moved;
      }
    }
    stored_triangles_ += add_checked(target(), a, b, c, material, normals, uvs, out_.stats) ? 1 : 0;
  }

  // "instances": a list of transforms, each placing the mesh once: to_world p = T + R (S p), the
  // "transform" object's meaning.
  std::vector<Affine> parse_instances(const Json& j, const std::string& where) const {
    if (!j.is_array()) fail(where, "must be a list of transforms, got " + describe(j));
    if (j.empty()) fail(where, "must list at least one transform (an empty list draws nothing)");
    std::vector<Affine> out;
    out.reserve(j.size());
    for (size_t k = 0; k < j.size(); ++k) {
      const Transform t = *parse_transform(j[k], where + "/" + std::to_string(k));
      Affine a;
      a.linear =
          t.rotate * glm::mat3(glm::vec3(t.scale.x, 0.0f, 0.0f), glm::vec3(0.0f, t.scale.y, 0.0f),
                               glm::vec3(0.0f, 0.0f, t.scale.z));
      a.translation = t.translate;
      out.push_back(a);
    }
    return out;
  }

  void parse_meshes(const Json& j) {
    array(j, "/meshes");
    if (j.empty()) fail("/meshes", "no geometry: the list is empty");
    for (size_t i = 0; i < j.size(); ++i) {
      const std::string where = "/meshes/" + std::to_string(i);
      object(j[i], where);
      check_keys(
          j[i], where,
          {"file", "generator", "positions", "triangles", "material", "transform", "instances"});
      const int sources =
          static_cast<int>(j[i].contains("file")) + static_cast<int>(j[i].contains("generator")) +
          static_cast<int>(j[i].contains("positions") || j[i].contains("triangles"));
      if (sources != 1) {
        fail(where,
             "needs exactly one source: \"file\", \"generator\", or \"positions\" with "
             "\"triangles\"");
      }
      std::optional<uint32_t> material;
      if (j[i].contains("material"))
        material = material_named(j[i]["material"], where + "/material");
      std::optional<Transform> transform;
      if (j[i].contains("transform"))
        transform = parse_transform(j[i]["transform"], where + "/transform");

      std::vector<Affine> placements;
      if (j[i].contains("instances")) {
        placements = parse_instances(j[i]["instances"], where + "/instances");
        out_.scene.prototypes.emplace_back();
        target_ = &out_.scene.prototypes.back();
      }

      if (j[i].contains("file")) {
        add_file(j[i]["file"], where + "/file", material, transform);
      } else if (j[i].contains("generator")) {
        add_generated(j[i]["generator"], where + "/generator", material, transform);
      } else {
        add_inline(j[i], where, material ? *material : default_material(), transform);
      }
      if (target_) {
        target_ = nullptr;
        if (out_.scene.prototypes.back().empty()) {
          out_.scene.prototypes.pop_back();  // every triangle dropped: nothing to place
        } else {
          const uint32_t prototype = static_cast<uint32_t>(out_.scene.prototypes.size() - 1);
          for (size_t k = 0; k < placements.size(); ++k) {
            try {
              add_instance(out_.scene, prototype, placements[k]);
            } catch (const Error& e) {
              fail(where + "/instances/" + std::to_string(k), e.reason());
            }
          }
        }
      }
      ++out_.stats.meshes;
    }
    if (out_.scene.mesh.empty() && out_.scene.instances.empty()) {
      fail("", "no geometry: every triangle was degenerate or non-finite (" +
                   std::to_string(out_.stats.dropped_degenerate) + " degenerate, " +
                   std::to_string(out_.stats.dropped_non_finite) + " non-finite)");
    }
  }

  void add_inline(const Json& j, const std::string& where, uint32_t material,
                  const std::optional<Transform>& t) {
    if (!j.contains("positions")) fail(where, "\"triangles\" needs \"positions\"");
    if (!j.contains("triangles")) fail(where, "\"positions\" needs \"triangles\"");
    const Json& p = array(j["positions"], where + "/positions");
    const Json& tris = array(j["triangles"], where + "/triangles");
    if (tris.empty()) fail(where + "/triangles", "mesh has no triangles");
    std::vector<glm::vec3> positions;
    positions.reserve(p.size());
    for (size_t k = 0; k < p.size(); ++k) {
      positions.push_back(vec3(p[k], where + "/positions/" + std::to_string(k)));
    }
    const long long last = static_cast<long long>(positions.size()) - 1;
    for (size_t k = 0; k < tris.size(); ++k) {
      const std::string at = where + "/triangles/" + std::to_string(k);
      if (!tris[k].is_array() || tris[k].size() != 3) {
        fail(at, "must be an array of 3 vertex indices, got " +
                     (tris[k].is_array() ? std::to_string(tris[k].size()) + " elements"
                                         : describe(tris[k])));
      }
      size_t idx[3];
      for (int c = 0; c < 3; ++c) {
        const Json& v = tris[k][c];
        const std::string at_c = at + "/" + std::to_string(c);
        if (last < 0) fail(at_c, "index out of range: \"positions\" is empty");
        if (!v.is_number_integer() && !v.is_number_unsigned()) {
          fail(at_c, "must be a vertex index (an integer from 0 to " + std::to_string(last) +
                         "), got " + describe(v));
        }
        if (v.is_number_unsigned() ? v.get<uint64_t>() > static_cast<uint64_t>(last)
                                   : (v.get<int64_t>() < 0 || v.get<int64_t>() > last)) {
          fail(at_c, "index " + describe(v) + " out of range (0 to " + std::to_string(last) + ")");
        }
        idx[c] = static_cast<size_t>(v.get<uint64_t>());
      }
      add(positions[idx[0]], positions[idx[1]], positions[idx[2]], material, t, at);
    }
  }

  void add_generated(const Json& j, const std::string& where, std::optional<uint32_t> material,
                     const std::optional<Transform>& t) {
    const std::string name = string(j, where);
    // The extension point for procedural sources: each name maps to a function that builds a
    // Scene; its triangles and materials join this scene (its camera and lights do not).
    std::optional<Scene> generated;
    try {
      generated = make_builtin_scene(name);
    } catch (const Error&) {
      fail(where,
           "unknown generator '" + shown(name) + "' (use " + std::string(kBuiltinSceneHelp) + ")");
    }
    const uint32_t offset = static_cast<uint32_t>(out_.scene.materials.size());
    if (!material) {
      for (const Material& m : generated->materials) add_material(m);
    }
    const TriangleMesh& g = generated->mesh;
    if (!t && !material) {
      // Copied as stored, so that a generated scene is bit-identical to the built-in one.
      if (stored_triangles_ + g.size() > kMaxSceneTriangles) {
        fail_too_many_triangles(where);
      }
      target().append(g, offset);
      stored_triangles_ += g.size();
      return;
    }
    for (size_t k = 0; k < g.size(); ++k) {
      add(g.vertex(k, 0), g.vertex(k, 1), g.vertex(k, 2),
          material ? *material : offset + g.material()[k], t, where);
    }
  }

  void add_file(const Json& j, const std::string& where, std::optional<uint32_t> material,
                const std::optional<Transform>& t) {
    const std::string name = string(j, where);
    if (name.empty()) fail(where, "must name a mesh file");
    const fs::path base = fs::path(path_).parent_path();
    const fs::path resolved = fs::path(name).is_absolute() ? fs::path(name) : base / name;
    const std::string file = resolved.string();
    const std::string referenced = " (referenced by " + path_ + " at " + where + ")";
    std::error_code ec;
    if (fs::equivalent(resolved, fs::path(path_), ec)) {
      fail(where, "'" + shown(name) + "' is this scene file itself; meshes must be mesh files");
    }
    if (lower(resolved.extension().string()) == ".json") {
      fail(where, "'" + shown(name) +
                      "' is a scene file; a scene cannot include another scene, only mesh files");
    }
    ImportedMesh imported;
    try {
      imported = options_.read_mesh ? options_.read_mesh(file) : import_mesh_file(file);
    } catch (const Error& e) {
      throw Error(e.subject(), e.reason() + referenced, e.exit_code());
    }
    const uint32_t offset = static_cast<uint32_t>(out_.scene.materials.size());
    if (!material) {
      const auto texture_offset = static_cast<int32_t>(out_.scene.textures.size());
      for (const TextureImage& t : imported.textures) {
        out_.scene.textures.push_back(Texture::from_image(t));
      }
      for (Material m : imported.materials) {
        for (TextureRef* r : m.texture_refs()) {
          if (r->present()) r->index += texture_offset;
        }
        add_material(m);
      }
    }
    AddOptions options;
    options.transform = t;
    options.material = material;
    options.material_offset = offset;
    options.materials = imported.materials.size();
    options.stored = stored_triangles_;
    options.max_triangles = kMaxSceneTriangles;
    options.tangents = imported.tangents;
    options.colours = imported.colours;
    options.uvs1 = imported.uvs1;
    TriangleMesh& mesh = target();
    const size_t before = mesh.size();
    switch (add_all_checked(mesh, imported.corner_view(), imported.material, imported.normals,
                            imported.uvs, options, out_.stats)) {
      case AddResult::kOk:
        break;
      case AddResult::kMaterialOutOfRange:
        fail(where, "mesh material index out of range");
      case AddResult::kTooManyTriangles:
        fail_too_many_triangles(where);
    }
    stored_triangles_ += mesh.size() - before;
    out_.stats.meshes += imported.meshes > 0 ? imported.meshes - 1 : 0;
  }

  void parse_output(const Json& j) {
    object(j, "/output");
    check_keys(j, "/output", {"file"});
    if (j.contains("file")) {
      const std::string file = string(j["file"], "/output/file");
      if (!image_format_for(file)) {
        fail("/output/file", "'" + shown(file) + "' has an unknown extension (use " +
                                 std::string(kImageExtensions) + ")");
      }
      out_.output = file;
    }
  }

  void parse_integrator(const Json& j) {
    object(j, "/integrator");
    check_keys(j, "/integrator", {"type", "spp", "max_depth", "seed", "sampler", "light_paths"});
    IntegratorSpec& spec = out_.integrator;
    if (j.contains("type")) {
      const std::string type = string(j["type"], "/integrator/type");
      if (type == "lab") {
        spec.kind = IntegratorSpec::Kind::kLab;
      } else if (type == "path") {
        spec.kind = IntegratorSpec::Kind::kPath;
      } else if (type == "bdpt") {
        spec.kind = IntegratorSpec::Kind::kBdpt;
      } else {
        fail("/integrator/type",
             "must be \"lab\", \"path\" or \"bdpt\", got '" + shown(type) + "'");
      }
    }
    if (j.contains("spp")) {
      spec.spp = static_cast<uint32_t>(integer_in(j["spp"], "/integrator/spp", 1, kMaxSpp));
    }
    if (j.contains("max_depth")) {
      spec.max_depth =
          static_cast<int>(integer_in(j["max_depth"], "/integrator/max_depth", 0, kMaxMaxDepth));
    }
    if (j.contains("seed")) {
      spec.seed = static_cast<uint64_t>(
          integer_in(j["seed"], "/integrator/seed", 0, std::numeric_limits<long long>::max()));
    }
    if (j.contains("sampler")) {
      const std::string name = string(j["sampler"], "/integrator/sampler");
      const std::optional<SamplerKind> kind = parse_sampler(name);
      if (!kind) {
        fail("/integrator/sampler",
             "must be \"sobol\" or \"independent\", got '" + shown(name) + "'");
      }
      spec.sampler = *kind;
    }
    if (j.contains("light_paths")) {
      const Json& v = j["light_paths"];
      const bool is_auto = v.is_string() && v.get<std::string>() == "auto";
      const double f = v.is_number() ? v.get<double>() : 0.0;
      if (is_auto) {
        spec.light_paths = 1.0f;
        spec.light_paths_auto = true;
      } else if (!(f >= 1e-6 && f <= 1.0)) {
        fail("/integrator/light_paths",
             "must be \"auto\" or the share of samples that trace a light subpath (bdpt), "
             "greater than 0 (at least 1e-6) and at most 1, got " +
                 describe(v));
      } else {
        spec.light_paths = static_cast<float>(f);
        spec.light_paths_auto = false;
      }
    }
  }

  std::string_view text_;
  const std::string& path_;
  const SceneFileOptions& options_;
  LoadedScene out_;
  std::map<std::string, uint32_t> named_;
  std::optional<uint32_t> default_material_;
  TriangleMesh* target_ = nullptr;
  size_t stored_triangles_ = 0;
  std::map<std::string, int32_t> textures_;  // resolved image path -> index in scene.textures
};

}  // namespace

size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

LoadedScene parse_scene_json(std::string_view text, const std::string& path,
                             const SceneFileOptions& options) {
  return Parser(text, path, options).run();
}

}  // namespace tritrace
