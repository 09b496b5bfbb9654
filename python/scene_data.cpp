// Scenes for the Python module through the library's own loaders and scene_from_mesh, so that a
// scene built from arrays is the scene a mesh file with those triangles gives.
#include "scene_data.h"

#include <cmath>
#include <limits>
#include <map>
#include <tuple>

#include "tritrace/error.h"
#include "tritrace/job/setting_values.h"
#include "tritrace/scene/io/mesh_import.h"
#include "tritrace/scene/io/scene_loader.h"
#include "tritrace/scene/io/triangle_filter.h"

namespace tritrace::python {
namespace {

std::shared_ptr<SceneData> wrap(LoadedScene loaded, std::string source) {
  // The module works on one triangle array (normals, counts and hits index it), so instances are
  // copied out into it: the same triangles in the same numbering as the CLI's instanced render
  // (Scene::triangle), at the memory of the copies.
  if (loaded.scene.has_instances()) loaded.scene = flattened(loaded.scene);
  auto data = std::make_shared<SceneData>();
  data->camera = loaded.scene.camera;
  data->lights = loaded.scene.lights;
  data->caller_triangles = loaded.scene.mesh.size();
  data->loaded = std::move(loaded);
  data->source = std::move(source);
  return data;
}

[[noreturn]] void fail(const std::string& argument, const std::string& reason) {
  throw Error(argument, reason, ExitCode::kUsage);
}

glm::vec3 row(std::span<const float> values, size_t i) {
  return {values[3 * i], values[3 * i + 1], values[3 * i + 2]};
}

std::string text(glm::vec3 v) {
  std::string out = "(";
  for (int i = 0; i < 3; ++i) {
    if (i > 0) out += ", ";
    out += format_float(v[i]);
  }
  return out + ")";
}

// The materials of ImportedMesh: one per distinct albedo, in order of first use.
void add_materials(std::span<const float> albedo, std::span<const uint32_t> kept,
                   ImportedMesh& mesh) {
  if (albedo.empty()) {
    mesh.materials.push_back(Material{.albedo = kNeutralGrey});
    mesh.material.assign(kept.size(), 0);
    return;
  }
  const bool one = albedo.size() == 3;
  for (size_t i = 0; i < albedo.size() / 3; ++i) {
    const glm::vec3 a = row(albedo, i);
    for (int k = 0; k < 3; ++k) {
      if (!(a[k] >= 0.0f && a[k] <= 1.0f)) {
        fail("materials",
             (one ? std::string("the albedo") : "the albedo of triangle " + std::to_string(i)) +
                 " must be in [0, 1], got " + text(a));
      }
    }
  }
  std::map<std::tuple<float, float, float>, uint32_t> index;
  mesh.material.reserve(kept.size());
  for (uint32_t t : kept) {
    const glm::vec3 a = row(albedo, one ? 0 : t);
    const auto [it, added] =
        index.try_emplace({a.x, a.y, a.z}, static_cast<uint32_t>(mesh.materials.size()));
    if (added) mesh.materials.push_back(Material{.albedo = a});
    mesh.material.push_back(it->second);
  }
}

}  // namespace

std::shared_ptr<SceneData> load_file(const std::string& path) {
  return wrap(load_scene(path), path);
}

std::shared_ptr<SceneData> load_builtin(const std::string& name) {
  return wrap(load_builtin_scene(name), name);
}

std::shared_ptr<SceneData> scene_from_arrays(std::span<const float> vertices,
                                             std::span<const int64_t> triangles,
                                             std::span<const float> albedo) {
  const size_t vertex_count = vertices.size() / 3;
  const size_t count = triangles.size() / 3;
  if (count == 0) fail("triangles", "no triangles given");
  if (count > kMaxSceneTriangles) {
    fail("triangles", "more than " + std::to_string(kMaxSceneTriangles) + " triangles");
  }
  ImportedMesh mesh;
  mesh.meshes = 1;
  LoadStats stats;
  std::vector<uint32_t> kept;
  kept.reserve(count);
  mesh.corners.reserve(3 * count);
  for (size_t t = 0; t < count; ++t) {
    glm::vec3 corner[3];
    for (int k = 0; k < 3; ++k) {
      const int64_t v = triangles[3 * t + k];
      if (v < 0 || static_cast<uint64_t>(v) >= vertex_count) {
        fail("triangles", "triangle " + std::to_string(t) + " refers to vertex " +
                              std::to_string(v) + ", but there are " +
                              std::to_string(vertex_count) + " vertices");
      }
      corner[k] = row(vertices, static_cast<size_t>(v));
    }
    // The loaders' gate (triangle_filter.h): dropped triangles could only ever be missed, or
    // break the arithmetic of those that can be hit.
    switch (check_triangle(corner[0], corner[1], corner[2])) {
      case TriangleCheck::kOk:
        kept.push_back(static_cast<uint32_t>(t));
        // The order mesh_import.cpp stores model files' triangles in (see SceneData).
        mesh.corners.insert(mesh.corners.end(), {corner[0], corner[2], corner[1]});
        break;
      case TriangleCheck::kDegenerate:
        ++stats.dropped_degenerate;
        break;
      case TriangleCheck::kNonFinite:
        ++stats.dropped_non_finite;
        break;
    }
  }
  if (kept.empty()) {
    fail("triangles", "no geometry: every triangle was degenerate or non-finite (" +
                          std::to_string(stats.dropped_degenerate) + " degenerate, " +
                          std::to_string(stats.dropped_non_finite) + " non-finite)");
  }
  add_materials(albedo, kept, mesh);
  LoadedScene loaded;
  try {
    loaded = scene_from_mesh(mesh);
  } catch (const Error& e) {
    fail("vertices", e.reason());
  }
  loaded.stats.dropped_degenerate = stats.dropped_degenerate;
  loaded.stats.dropped_non_finite = stats.dropped_non_finite;
  auto data = wrap(std::move(loaded), "arrays");
  data->caller_triangles = count;
  data->caller_order_swapped = true;
  if (kept.size() < count) {
    data->caller_index = std::move(kept);
    data->scene_index.assign(count, -1);
    for (size_t i = 0; i < data->caller_index.size(); ++i) {
      data->scene_index[data->caller_index[i]] = static_cast<int32_t>(i);
    }
  }
  return data;
}

View make_view(const SceneData& data, const CameraPose& pose, const SceneOverrides& overrides) {
  LoadedScene view;  // no geometry: apply_overrides reads only the camera description and lights
  view.camera = data.loaded.camera;
  view.scene.lights = data.lights;
  CameraSpec& c = view.camera;
  if (pose.any() && c.lab_orbit) {
    // The orbit camera's pose as a look-at camera; its focal length stays the image height.
    c.lab_orbit = false;
  }
  if (pose.position) c.position = *pose.position;
  if (pose.look_at) c.look_at = *pose.look_at;
  if (pose.up) c.up = *pose.up;
  if (pose.vertical_fov_degrees && pose.focal_length_px) {
    fail("vertical_fov", "give either vertical_fov or focal_length, not both");
  }
  if (pose.vertical_fov_degrees) {
    const double fov = *pose.vertical_fov_degrees;
    if (!(fov > 0.0 && fov < 180.0)) {
      fail("vertical_fov",
           "must be between 0 and 180 degrees (exclusive), got " + format_double(fov));
    }
    c.vertical_fov_degrees = fov;
    c.focal_length_px.reset();
    c.ortho_half_height.reset();  // a field of view makes a perspective camera
  }
  if (pose.focal_length_px) {
    const float f = *pose.focal_length_px;
    if (!(f > 0.0f && f <= std::numeric_limits<float>::max())) {
      fail("focal_length", "must be positive, got " + format_float(f));
    }
    c.focal_length_px = f;
    c.vertical_fov_degrees.reset();
    c.ortho_half_height.reset();
  }
  if (pose.any() && !Camera::is_valid_look_at(c.position, c.look_at, c.up)) {
    fail(pose.position  ? "position"
         : pose.look_at ? "look_at"
                        : "up",
         "position and look_at must differ, and up must not be parallel to the viewing "
         "direction");
  }
  apply_overrides(view, overrides);
  return {view.scene.camera, std::move(view.scene.lights)};
}

ViewLock::ViewLock(SceneData& data, const View& view) : data_(data), lock_(data.view_mutex) {
  data_.loaded.scene.camera = view.camera;
  data_.loaded.scene.lights = view.lights;
}

ViewLock::~ViewLock() {
  data_.loaded.scene.camera = data_.camera;
  data_.loaded.scene.lights = data_.lights;
}

}  // namespace tritrace::python
