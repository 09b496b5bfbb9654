// KHR_lights_punctual from a glTF document's JSON: the light table checked field by field, the
// scene's node tree walked for the world transforms, the units converted as Blender does.
#include "tritrace/scene/io/gltf_lights.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <nlohmann/json.hpp>
#include <numbers>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/scene/io/gltf_json.h"

namespace tritrace {
namespace {

using Json = nlohmann::json;

// Whether each coordinate survives rounding to float.
bool finite(glm::dvec3 v) {
  return std::isfinite(static_cast<float>(v.x)) && std::isfinite(static_cast<float>(v.y)) &&
         std::isfinite(static_cast<float>(v.z));
}

// One light of the extension's table, in its own units and space (at the origin, along -z).
struct LightDef {
  enum class Type { kPoint, kSpot, kDirectional } type = Type::kPoint;
  glm::dvec3 rgb{1.0};  // colour times intensity, still in candela or lux
  double inner = 0.0, outer = std::numbers::pi / 4.0;
};

class LightReader {
 public:
  explicit LightReader(const std::string& subject) : subject_(subject) {}

  PunctualLights run(const Json& doc) {
    if (!doc.is_object()) fail("", "a glTF document must be a JSON object");
    read_table(doc);
    if (defs_.empty()) return {};
    if (!doc.contains("nodes")) return {};
    const Json& nodes = doc["nodes"];
    if (!nodes.is_array()) fail("/nodes", "must be an array");
    // The default scene's roots; a file without scenes places nothing (nothing is drawn either).
    if (!doc.contains("scenes")) return {};
    const Json& scenes = doc["scenes"];
    if (!scenes.is_array() || scenes.empty()) return {};
    size_t scene = 0;
    if (doc.contains("scene")) scene = index(doc["scene"], "/scene", scenes.size());
    const Json& roots = scenes[scene].value("nodes", Json::array());
    if (!roots.is_array()) fail("/scenes/" + std::to_string(scene) + "/nodes", "must be an array");
    PunctualLights out;
    // Depth-first in the file's order (children pushed last first), each entry a node with its
    // parent's world matrix. A tree never holds more levels than nodes, so a deeper walk means a
    // cycle; a node listed as the child of several (which glTF forbids) is walked once per path,
    // up to a bound that keeps a malicious file from taking exponential time.
    constexpr size_t kMaxVisits = size_t{1} << 20;
    size_t visits = 0;
    std::vector<std::pair<size_t, glm::dmat4>> stack;
    std::vector<size_t> depth;
    for (size_t r = roots.size(); r-- > 0;) {
      stack.emplace_back(
          index(roots[r], "/scenes/" + std::to_string(scene) + "/nodes/" + std::to_string(r),
                nodes.size()),
          glm::dmat4(1.0));
      depth.push_back(1);
    }
    while (!stack.empty()) {
      if (++visits > kMaxVisits) {
        fail("/nodes", "reach more than " + std::to_string(kMaxVisits) +
                           " placements (nodes listed as children of several)");
      }
      const auto [n, parent] = stack.back();
      const size_t level = depth.back();
      stack.pop_back();
      depth.pop_back();
      const std::string where = "/nodes/" + std::to_string(n);
      if (level > nodes.size()) fail(where, "is its own ancestor (the node graph has a cycle)");
      const Json& node = nodes[n];
      if (!node.is_object()) fail(where, "must be an object");
      const glm::dmat4 world = parent * local_matrix(node, where);
      place(node, where, world, out);
      if (node.contains("children")) {
        const Json& children = node["children"];
        if (!children.is_array()) fail(where + "/children", "must be an array");
        for (size_t c = children.size(); c-- > 0;) {
          stack.emplace_back(
              index(children[c], where + "/children/" + std::to_string(c), nodes.size()), world);
          depth.push_back(level + 1);
        }
      }
    }
    return out;
  }

 private:
  [[noreturn]] void fail(const std::string& where, const std::string& reason) const {
    throw Error(subject_, where.empty() ? reason : where + ": " + reason);
  }

  double number(const Json& j, const std::string& where) const {
    if (!j.is_number()) fail(where, "must be a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(where, "must be finite");
    return v;
  }

  size_t index(const Json& j, const std::string& where, size_t count) const {
    if (!j.is_number_unsigned() || j.get<uint64_t>() >= count) {
      fail(where, "must be an index below " + std::to_string(count));
    }
    return static_cast<size_t>(j.get<uint64_t>());
  }

  template <size_t N>
  std::array<double, N> numbers(const Json& j, const std::string& where) const {
    if (!j.is_array() || j.size() != N) {
      fail(where, "must be an array of " + std::to_string(N) + " numbers");
    }
    std::array<double, N> v;
    for (size_t i = 0; i < N; ++i) v[i] = number(j[i], where + "/" + std::to_string(i));
    return v;
  }

  void read_table(const Json& doc) {
    if (!doc.contains("extensions")) return;
    const Json& ext = doc["extensions"];
    if (!ext.is_object() || !ext.contains("KHR_lights_punctual")) return;
    const std::string base = "/extensions/KHR_lights_punctual";
    const Json& table = ext["KHR_lights_punctual"];
    if (!table.is_object()) fail(base, "must be an object");
    if (!table.contains("lights")) return;
    const Json& lights = table["lights"];
    if (!lights.is_array()) fail(base + "/lights", "must be an array");
    for (size_t i = 0; i < lights.size(); ++i) {
      const std::string where = base + "/lights/" + std::to_string(i);
      const Json& l = lights[i];
      if (!l.is_object()) fail(where, "must be an object");
      LightDef def;
      if (!l.contains("type") || !l["type"].is_string()) {
        fail(where + "/type", "must be \"point\", \"spot\" or \"directional\"");
      }
      const std::string type = l["type"].get<std::string>();
      if (type == "point") {
        def.type = LightDef::Type::kPoint;
      } else if (type == "spot") {
        def.type = LightDef::Type::kSpot;
      } else if (type == "directional") {
        def.type = LightDef::Type::kDirectional;
      } else {
        fail(where + "/type", "must be \"point\", \"spot\" or \"directional\"");
      }
      glm::dvec3 color(1.0);
      if (l.contains("color")) {
        const auto c = numbers<3>(l["color"], where + "/color");
        for (size_t k = 0; k < 3; ++k) {
          if (c[k] < 0.0) fail(where + "/color/" + std::to_string(k), "must not be negative");
        }
        color = {c[0], c[1], c[2]};
      }
      double intensity = 1.0;
      if (l.contains("intensity")) {
        intensity = number(l["intensity"], where + "/intensity");
        if (intensity < 0.0) fail(where + "/intensity", "must not be negative");
      }
      def.rgb = color * intensity;
      if (def.type == LightDef::Type::kSpot) {
        // The specification's defaults and bounds: 0 <= inner < outer <= pi / 2.
        const Json& spot = l.value("spot", Json::object());
        if (!spot.is_object()) fail(where + "/spot", "must be an object");
        if (spot.contains("outerConeAngle")) {
          def.outer = number(spot["outerConeAngle"], where + "/spot/outerConeAngle");
          if (!(def.outer > 0.0 && def.outer <= std::numbers::pi / 2.0)) {
            fail(where + "/spot/outerConeAngle", "must be more than 0 and at most pi/2");
          }
        }
        if (spot.contains("innerConeAngle")) {
          def.inner = number(spot["innerConeAngle"], where + "/spot/innerConeAngle");
          if (!(def.inner >= 0.0 && def.inner < def.outer)) {
            fail(where + "/spot/innerConeAngle", "must be at least 0 and less than outerConeAngle");
          }
        }
        if (!(std::cos(def.inner) > std::cos(def.outer))) {
          fail(where + "/spot", "innerConeAngle and outerConeAngle are too close to tell apart");
        }
      }
      defs_.push_back(def);
    }
  }

  // The node's own transform: its matrix, or translation * rotation * scale.
  glm::dmat4 local_matrix(const Json& node, const std::string& where) const {
    if (node.contains("matrix")) {
      const auto m = numbers<16>(node["matrix"], where + "/matrix");
      glm::dmat4 out;
      for (int c = 0; c < 4; ++c) {
        for (int r = 0; r < 4; ++r) out[c][r] = m[static_cast<size_t>(4 * c + r)];  // column-major
      }
      return out;
    }
    glm::dmat4 t(1.0), r(1.0), s(1.0);
    if (node.contains("translation")) {
      const auto v = numbers<3>(node["translation"], where + "/translation");
      t[3] = glm::dvec4(v[0], v[1], v[2], 1.0);
    }
    if (node.contains("rotation")) {
      const auto q = numbers<4>(node["rotation"], where + "/rotation");  // x, y, z, w
      const glm::dquat quat(q[3], q[0], q[1], q[2]);
      const double len = glm::length(quat);
      if (!(len > 0.0)) fail(where + "/rotation", "must not be the zero quaternion");
      r = glm::mat4_cast(quat / len);
    }
    if (node.contains("scale")) {
      const auto v = numbers<3>(node["scale"], where + "/scale");
      s[0][0] = v[0];
      s[1][1] = v[1];
      s[2][2] = v[2];
    }
    return t * r * s;
  }

  // The light this node refers to, if any, placed by the node's world matrix.
  void place(const Json& node, const std::string& where, const glm::dmat4& world,
             PunctualLights& out) const {
    if (!node.contains("extensions")) return;
    const Json& ext = node["extensions"];
    if (!ext.is_object() || !ext.contains("KHR_lights_punctual")) return;
    const Json& ref = ext["KHR_lights_punctual"];
    const std::string at = where + "/extensions/KHR_lights_punctual";
    if (!ref.is_object() || !ref.contains("light")) fail(at, "must name a \"light\"");
    const LightDef& def = defs_[index(ref["light"], at + "/light", defs_.size())];
    const glm::dvec3 position(world[3]);
    glm::dvec3 direction = glm::dmat3(world) * glm::dvec3(0.0, 0.0, -1.0);
    const double len = glm::length(direction);
    const glm::vec3 rgb(def.rgb / kGltfLumensPerWatt);
    if (!std::isfinite(rgb.x + rgb.y + rgb.z) || !finite(position)) {
      fail(where, "places a light beyond float range (its position or colour times intensity)");
    }
    if (def.type == LightDef::Type::kPoint) {
      out.points.push_back({glm::vec3(position), rgb * static_cast<float>(4.0 * std::numbers::pi)});
      return;
    }
    if (!(len > 0.0) || !std::isfinite(len)) fail(where, "scales its light's direction to zero");
    direction /= len;
    if (def.type == LightDef::Type::kDirectional) {
      out.directionals.push_back({glm::vec3(direction), rgb});
      return;
    }
    SpotLight s;
    s.position = glm::vec3(position);
    s.direction = glm::vec3(direction);
    s.intensity = rgb;
    s.cos_inner = static_cast<float>(std::cos(def.inner));
    s.cos_outer = static_cast<float>(std::cos(def.outer));
    s.falloff = SpotFalloff::kGltf;
    out.spots.push_back(s);
  }

  std::string subject_;
  std::vector<LightDef> defs_;
};

}  // namespace

bool is_gltf_file(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return ext == ".gltf" || ext == ".glb";
}

PunctualLights parse_gltf_lights(std::string_view json, const std::string& subject) {
  // Most files have no lights; a .gltf with its buffers inline can be hundreds of MB of base64,
  // not worth parsing a second time (assimp has read it) to find none.
  if (json.find("KHR_lights_punctual") == std::string_view::npos) return {};
  Json doc;
  try {
    doc = Json::parse(json);
  } catch (const Json::exception&) {
    throw Error(subject, "invalid glTF JSON (reading its lights)");
  }
  return LightReader(subject).run(doc);
}

PunctualLights read_gltf_lights(const std::string& path) {
  return parse_gltf_lights(read_gltf_json_text(path), path);
}

}  // namespace tritrace
