// Reading glTF 2.0 cameras from the file's JSON (the glTF 2.0 specification, sections 3.5 "Nodes
// and hierarchy" and 3.10 "Cameras"), and turning one into tritrace's camera description.
#include "tritrace/scene/io/gltf_cameras.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <sstream>

#include "tritrace/error.h"
#include "tritrace/scene/io/gltf_json.h"

namespace tritrace {
namespace {

using Json = nlohmann::json;

double number(const Json& j, const char* key, const std::string& where, const std::string& path) {
  if (!j.contains(key) || !j[key].is_number()) {
    throw Error(path, where + ": \"" + key + "\" must be a number");
  }
  const double v = j[key].get<double>();
  if (!std::isfinite(v)) throw Error(path, where + ": \"" + key + "\" must be finite");
  return v;
}

// A node's local transform: its matrix (column-major), else translation * rotation * scale.
glm::dmat4 local_transform(const Json& node, const std::string& where, const std::string& path) {
  const auto numbers = [&](const char* key, size_t count) {
    const Json& a = node[key];
    if (!a.is_array() || a.size() != count) {
      throw Error(path,
                  where + ": \"" + key + "\" must hold " + std::to_string(count) + " numbers");
    }
    std::vector<double> v;
    for (const Json& x : a) {
      if (!x.is_number() || !std::isfinite(x.get<double>())) {
        throw Error(path, where + ": \"" + key + "\" must hold finite numbers");
      }
      v.push_back(x.get<double>());
    }
    return v;
  };
  glm::dmat4 m(1.0);
  if (node.contains("matrix")) {
    const std::vector<double> v = numbers("matrix", 16);
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 4; ++r) m[c][r] = v[static_cast<size_t>(4 * c + r)];
    }
    return m;
  }
  if (node.contains("translation")) {
    const std::vector<double> t = numbers("translation", 3);
    m[3] = glm::dvec4(t[0], t[1], t[2], 1.0);
  }
  if (node.contains("rotation")) {
    const std::vector<double> q = numbers("rotation", 4);  // x, y, z, w
    const glm::dquat r(q[3], q[0], q[1], q[2]);
    const double len = glm::length(r);
    if (!(len > 0.0)) throw Error(path, where + ": \"rotation\" is a zero quaternion");
    m = m * glm::dmat4(glm::mat3_cast(r / len));
  }
  if (node.contains("scale")) {
    const std::vector<double> s = numbers("scale", 3);
    m = m * glm::dmat4(glm::dmat3(s[0], 0, 0, 0, s[1], 0, 0, 0, s[2]));
  }
  return m;
}

GltfCamera parse_camera(const Json& cameras, size_t index, const std::string& path) {
  const std::string where = "cameras[" + std::to_string(index) + "]";
  if (!cameras.is_array() || index >= cameras.size() || !cameras[index].is_object()) {
    throw Error(path, "a node refers to " + where + ", which the file does not have");
  }
  const Json& c = cameras[index];
  GltfCamera out;
  if (c.contains("name") && c["name"].is_string()) out.name = c["name"].get<std::string>();
  const std::string type = c.value("type", std::string());
  if (type == "perspective") {
    const Json& p = c.value("perspective", Json::object());
    out.yfov = number(p, "yfov", where + ".perspective", path);
    if (!(out.yfov > 0.0 && out.yfov < std::numbers::pi)) {
      throw Error(path, where + ".perspective: \"yfov\" must be between 0 and pi radians");
    }
    if (p.contains("aspectRatio")) {
      const double a = number(p, "aspectRatio", where + ".perspective", path);
      if (!(a > 0.0)) throw Error(path, where + ".perspective: \"aspectRatio\" must be positive");
      out.aspect_ratio = a;
    }
  } else if (type == "orthographic") {
    const Json& o = c.value("orthographic", Json::object());
    out.orthographic = true;
    out.xmag = number(o, "xmag", where + ".orthographic", path);
    out.ymag = number(o, "ymag", where + ".orthographic", path);
    // glTF forbids 0; a negative magnification would mirror the image.
    if (!(out.ymag > 0.0 && out.ymag < 1e30)) {
      throw Error(path, where + ".orthographic: \"ymag\" must be positive");
    }
  } else {
    throw Error(path, where + ": \"type\" must be \"perspective\" or \"orthographic\"");
  }
  return out;
}

}  // namespace

std::vector<GltfCamera> read_gltf_cameras(const std::string& path) {
  Json j;
  try {
    j = Json::parse(read_gltf_json_text(path));
  } catch (const Json::exception& e) {
    throw Error(path, std::string("glTF JSON: ") + e.what());
  }
  std::vector<GltfCamera> out;
  if (!j.is_object() || !j.contains("cameras")) return out;
  const Json& nodes = j.value("nodes", Json::array());
  const Json& cameras = j["cameras"];
  if (!nodes.is_array()) return out;

  // The roots: the scene's nodes, else every node that is no node's child.
  std::vector<size_t> roots;
  const Json& scenes = j.value("scenes", Json::array());
  if (scenes.is_array() && !scenes.empty()) {
    size_t scene = 0;
    if (j.contains("scene") && j["scene"].is_number_unsigned()) scene = j["scene"].get<size_t>();
    if (scene >= scenes.size()) throw Error(path, "\"scene\" names a scene the file lacks");
    for (const Json& n : scenes[scene].value("nodes", Json::array())) {
      if (n.is_number_unsigned()) roots.push_back(n.get<size_t>());
    }
  } else {
    std::vector<bool> child(nodes.size(), false);
    for (const Json& n : nodes) {
      for (const Json& c : n.value("children", Json::array())) {
        if (c.is_number_unsigned() && c.get<size_t>() < nodes.size()) child[c.get<size_t>()] = true;
      }
    }
    for (size_t i = 0; i < nodes.size(); ++i) {
      if (!child[i]) roots.push_back(i);
    }
  }

  // Depth first with an explicit stack (children pushed in reverse, so they come out in order).
  std::set<size_t> visited;
  std::vector<std::pair<size_t, glm::dmat4>> stack;
  for (auto r = roots.rbegin(); r != roots.rend(); ++r) stack.emplace_back(*r, glm::dmat4(1.0));
  while (!stack.empty()) {
    const auto [index, parent] = stack.back();
    stack.pop_back();
    if (index >= nodes.size() || !visited.insert(index).second) continue;
    const Json& node = nodes[index];
    if (!node.is_object()) continue;
    const std::string where = "nodes[" + std::to_string(index) + "]";
    const glm::dmat4 world = parent * local_transform(node, where, path);
    if (node.contains("camera") && node["camera"].is_number_unsigned()) {
      GltfCamera camera = parse_camera(cameras, node["camera"].get<size_t>(), path);
      if (node.contains("name") && node["name"].is_string() &&
          !node["name"].get<std::string>().empty()) {
        camera.name = node["name"].get<std::string>();
      }
      camera.world = world;
      out.push_back(camera);
    }
    const Json& children = node.value("children", Json::array());
    for (size_t k = children.size(); k-- > 0;) {
      if (children[k].is_number_unsigned()) stack.emplace_back(children[k].get<size_t>(), world);
    }
  }
  return out;
}

std::string describe(const GltfCamera& camera) {
  std::ostringstream s;
  if (camera.orthographic) {
    s << "orthographic, xmag " << camera.xmag << ", ymag " << camera.ymag;
  } else {
    s << "perspective, yfov " << camera.yfov << " rad (" << camera.yfov * 180.0 / std::numbers::pi
      << " deg)";
    if (camera.aspect_ratio) s << ", aspect " << *camera.aspect_ratio;
  }
  const glm::dvec3 p(camera.world[3]);
  s << ", at (" << p.x << ", " << p.y << ", " << p.z << ")";
  return s.str();
}

size_t choose_camera(const std::vector<GltfCamera>& cameras, const std::string& selection,
                     const std::string& path) {
  if (cameras.empty()) {
    throw Error("--camera", path + " has no cameras", ExitCode::kUsage);
  }
  if (selection.empty()) return 0;
  std::string list;
  for (size_t i = 0; i < cameras.size(); ++i) {
    list += (i ? ", " : "") + std::to_string(i);
    if (!cameras[i].name.empty()) list += " '" + cameras[i].name + "'";
  }
  const bool digits = std::all_of(selection.begin(), selection.end(),
                                  [](unsigned char ch) { return std::isdigit(ch) != 0; });
  if (digits) {
    // A name made only of digits is still found by its name when no index matches.
    if (selection.size() <= 9 && std::stoul(selection) < cameras.size()) {
      return std::stoul(selection);
    }
  }
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i].name == selection) return i;
  }
  throw Error("--camera", "no camera '" + selection + "' in " + path + " (it has " + list + ")",
              ExitCode::kUsage);
}

void set_gltf_view(const GltfCamera& camera, const Bounds3& bounds, CameraSpec* spec) {
  const glm::dmat4& w = camera.world;
  const glm::dvec3 eye(w[3]);
  const glm::dvec3 forward = glm::normalize(glm::dvec3(w * glm::dvec4(0, 0, -1, 0)));
  const glm::dvec3 up = glm::normalize(glm::dvec3(w * glm::dvec4(0, 1, 0, 0)));
  const glm::dvec3 right = glm::normalize(glm::dvec3(w * glm::dvec4(1, 0, 0, 0)));
  const glm::dvec3 centre = 0.5 * (glm::dvec3(bounds.lo) + glm::dvec3(bounds.hi));
  double depth = glm::dot(centre - eye, forward);
  if (!(depth > 0.0) || !std::isfinite(depth)) depth = 1.0;
  spec->position = glm::vec3(eye);
  spec->look_at = glm::vec3(eye + depth * forward);
  spec->up = glm::vec3(up);
  // Camera::look_at's right is cross(forward, up): the camera's +x unless the node mirrors.
  spec->mirror_x = glm::dot(glm::cross(forward, up), right) < 0.0;
  spec->vertical_fov_degrees.reset();
  spec->focal_length_px.reset();
  spec->ortho_half_height.reset();
  if (camera.orthographic) {
    spec->ortho_half_height = static_cast<float>(camera.ymag);
  } else {
    spec->vertical_fov_degrees = camera.yfov * 180.0 / std::numbers::pi;
  }
}

}  // namespace tritrace
