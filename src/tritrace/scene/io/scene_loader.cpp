// Dispatch by extension, the default camera and light for a bare mesh, and command-line overrides.
#include "tritrace/scene/io/scene_loader.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <filesystem>
#include <glm/geometric.hpp>
#include <numbers>

#include "tritrace/error.h"
#include "tritrace/math/rotation.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/io/gltf_cameras.h"
#include "tritrace/scene/io/input_file.h"
#include "tritrace/scene/io/pbrt_scene.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/triangle_filter.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

bool finite(glm::dvec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::abs(v.x) <= 3e38 &&
         std::abs(v.y) <= 3e38 && std::abs(v.z) <= 3e38;
}

// --camera for a file that has one camera of its own (a scene file, a pbrt file) or none.
[[noreturn]] void no_cameras(const std::string& path) {
  throw Error("--camera",
              "picks one of a glTF file's cameras; " + path + " has no cameras to choose from",
              ExitCode::kUsage);
}

}  // namespace

void apply_overrides(LoadedScene& loaded, const SceneOverrides& overrides) {
  CameraSpec c = loaded.camera;  // a copy: the description stays as loaded (see the header)
  if (overrides.width) c.width = *overrides.width;
  if (overrides.height) c.height = *overrides.height;
  if (overrides.light) {
    if (loaded.scene.lights.empty()) {
      loaded.scene.lights.push_back({*overrides.light, kLabLightPower});
    } else {
      loaded.scene.lights.front().position = *overrides.light;
    }
  }
  if (overrides.aperture) c.aperture_radius = *overrides.aperture;
  if (overrides.focus) {
    if (!(c.aperture_radius > 0.0f)) {
      throw Error("--focus",
                  "sets the distance a lens focuses at, and the camera has none (give --aperture)",
                  ExitCode::kUsage);
    }
    c.focus_distance = *overrides.focus;
  }
  if (c.lab_orbit) {
    const float distance = overrides.distance.value_or(glm::length(c.position - c.look_at));
    loaded.scene.camera = Camera(c.width, c.height, overrides.yaw.value_or(0.0), distance);
    // The orbit camera looks at the origin from `distance` away.
    if (c.aperture_radius > 0.0f) {
      loaded.scene.camera =
          loaded.scene.camera.with_lens(c.aperture_radius, c.focus_distance.value_or(distance));
    }
    return;
  }
  // Distance first, then the orbit: both keep the camera on a sphere about look_at.
  if (overrides.distance) {
    const glm::dvec3 from_target = glm::dvec3(c.position) - glm::dvec3(c.look_at);
    // Multiplied before dividing, so that round numbers stay exact ((0, 0, -3) * 2 / 3).
    const glm::dvec3 moved = glm::dvec3(c.look_at) +
                             from_target * double{*overrides.distance} / glm::length(from_target);
    if (!finite(moved)) {
      throw Error("--distance", "puts the camera beyond float range", ExitCode::kUsage);
    }
    c.position = glm::vec3(moved);
    if (!Camera::is_valid_look_at(c.position, c.look_at, c.up)) {
      throw Error("--distance", "puts the camera on the point it looks at", ExitCode::kUsage);
    }
  }
  if (overrides.yaw) {
    const RotationY r = RotationY::from_angle(*overrides.yaw);
    c.position = c.look_at + r.apply(c.position - c.look_at);
    if (!Camera::is_valid_look_at(c.position, c.look_at, c.up)) {
      throw Error("--yaw", "turns the camera to look along its up direction", ExitCode::kUsage);
    }
  }
  float focal = 0.0f;  // the lab's default: the image height
  if (c.vertical_fov_degrees)
    focal = Camera::focal_for_vertical_fov(c.height, *c.vertical_fov_degrees);
  if (c.focal_length_px) focal = *c.focal_length_px;
  Camera& camera = loaded.scene.camera;
  camera = Camera::look_at(c.width, c.height, c.position, c.look_at, c.up, focal);
  if (c.mirror_x) camera = camera.mirrored_x();
  if (c.ortho_half_height) camera = camera.orthographic(2.0f * *c.ortho_half_height / c.height);
  if (c.aperture_radius > 0.0f) {
    camera = camera.with_lens(c.aperture_radius,
                              c.focus_distance.value_or(glm::length(c.look_at - c.position)));
  }
}

bool is_scene_file(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return ext == ".json";
}

LoadedScene load_builtin_scene(const std::string& name, const SceneOverrides& overrides) {
  if (!overrides.camera.empty()) {
    throw Error("--camera", "picks one of a glTF file's cameras; the built-in scenes have one",
                ExitCode::kUsage);
  }
  LoadedScene loaded;
  // The geometry does not depend on the view; apply_overrides sets camera and light.
  loaded.scene = make_builtin_scene(name, CornellOptions{});
  // The lab's own scenes keep the lab's shading; the area-lit box is for the path tracer.
  loaded.integrator.kind =
      name == "cornell-area" ? IntegratorSpec::Kind::kPath : IntegratorSpec::Kind::kLab;
  loaded.camera.position = glm::vec3(0.0f, 0.0f, -kLabCameraDistance);
  loaded.camera.lab_orbit = true;
  loaded.stats.meshes = 1;
  apply_overrides(loaded, overrides);
  return loaded;
}

LoadedScene scene_from_mesh(const ImportedMesh& mesh, const SceneOverrides& overrides,
                            const PunctualLights& lights) {
  LoadedScene loaded;
  Scene& scene = loaded.scene;
  scene.materials = mesh.materials;
  for (const TextureImage& t : mesh.textures) scene.textures.push_back(Texture::from_image(t));
  AddOptions options;
  options.tangents = mesh.tangents;
  options.colours = mesh.colours;
  options.uvs1 = mesh.uvs1;
  [[maybe_unused]] const AddResult added = add_all_checked(
      scene.mesh, mesh.corner_view(), mesh.material, mesh.normals, mesh.uvs, options, loaded.stats);
  assert(added == AddResult::kOk);
  loaded.stats.meshes = mesh.meshes;
  if (scene.mesh.empty()) {
    throw Error("", "no geometry: every triangle was degenerate or non-finite (" +
                        std::to_string(loaded.stats.dropped_degenerate) + " degenerate, " +
                        std::to_string(loaded.stats.dropped_non_finite) + " non-finite)");
  }
  scene.ambient = kLabAmbient;
  // The default key light and grey environment only for a file that brings no light of its own.
  if (lights.empty()) scene.environment = glm::vec3(kDefaultEnvironmentRadiance);

  // Frame the bounding sphere in the vertical field of view, seen from the front (+z) and a
  // little above, with y up.
  const Bounds3 b = scene.mesh.bounds();
  const glm::dvec3 lo(b.lo), hi(b.hi);
  const glm::dvec3 centre = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * glm::length(hi - lo), 1e-30);
  const double half_fov = kFramingFovDegrees * std::numbers::pi / 360.0;
  const double distance = 1.1 * radius / std::sin(half_fov);
  const glm::dvec3 view_dir = glm::normalize(glm::dvec3(0.0, 0.35, 1.0));
  const glm::dvec3 eye = centre + distance * view_dir;
  const glm::dvec3 light = eye + radius * glm::dvec3(-0.3, 0.5, 0.0);
  const double to_surface = std::max(glm::length(light - centre) - radius, 0.1 * radius);
  const double power = kFramingIrradiance * 4.0 * std::numbers::pi * to_surface * to_surface;
  if (!finite(eye) || !finite(light) || !std::isfinite(power) || power > 3e38 || power <= 0.0) {
    throw Error("", "the mesh's bounds are too large or too small to frame a camera on");
  }
  loaded.camera.position = glm::vec3(eye);
  loaded.camera.look_at = glm::vec3(centre);
  loaded.camera.up = glm::vec3(0.0f, 1.0f, 0.0f);
  loaded.camera.vertical_fov_degrees = kFramingFovDegrees;
  if (lights.empty()) {
    scene.lights.push_back({glm::vec3(light), glm::vec3(static_cast<float>(power))});
  } else {
    scene.lights = lights.points;
    scene.spot_lights = lights.spots;
    scene.directional_lights = lights.directionals;
  }
  apply_overrides(loaded, overrides);
  return loaded;
}

LoadedScene load_scene(const std::string& path, const SceneOverrides& overrides) {
  if (is_scene_file(path)) {
    if (!overrides.camera.empty()) no_cameras(path);
    LoadedScene loaded = parse_scene_json(read_input_file(path), path);
    apply_overrides(loaded, overrides);
    return loaded;
  }
  if (is_pbrt_file(path)) {
    if (!overrides.camera.empty()) no_cameras(path);
    LoadedScene loaded = load_pbrt_scene(path);
    apply_overrides(loaded, overrides);
    return loaded;
  }
  const ImportedMesh mesh = import_mesh_file(path);
  const PunctualLights lights = is_gltf_file(path) ? read_gltf_lights(path) : PunctualLights{};
  LoadedScene loaded;
  try {
    loaded = scene_from_mesh(mesh, overrides, lights);
  } catch (const Error& e) {
    if (!e.subject().empty()) throw;
    throw Error(path, e.reason(), e.exit_code());
  }
  const std::vector<GltfCamera> cameras =
      is_gltf_file(path) ? read_gltf_cameras(path) : std::vector<GltfCamera>{};
  if (cameras.empty()) {
    if (!overrides.camera.empty()) no_cameras(path);
    return loaded;
  }
  // The file's camera replaces the framing's (the lights, the file's or the default key light
  // placed with the framing, stay as scene_from_mesh made them).
  const size_t chosen = choose_camera(cameras, overrides.camera, path);
  for (const GltfCamera& c : cameras) loaded.cameras.push_back({c.name, describe(c)});
  loaded.camera_index = static_cast<int>(chosen);
  set_gltf_view(cameras[chosen], loaded.scene.mesh.bounds(), &loaded.camera);
  apply_overrides(loaded, overrides);
  return loaded;
}

}  // namespace tritrace
