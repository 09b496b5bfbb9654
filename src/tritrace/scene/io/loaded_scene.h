// What loading a scene file produces: the Scene itself plus the facts `tritrace info` reports
// (meshes, dropped triangles) and the file's output settings, and the camera as a description that
// command-line overrides can still change before it becomes a Camera.
#pragma once

#include <cstddef>
#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tritrace/image/image_limits.h"  // kMaxImageSide
#include "tritrace/scene/integrator_spec.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// The lab's image size, used when neither the scene nor the command line gives one.
inline constexpr int kDefaultImageSide = 500;

struct CameraSpec {
  int width = kDefaultImageSide;
  int height = kDefaultImageSide;
  glm::vec3 position{0.0f, 0.0f, -3.0f};  // the lab's
  glm::vec3 look_at{0.0f};
  glm::vec3 up{0.0f, -1.0f, 0.0f};  // the lab's world y points down
  // At most one is set; with neither, the focal length is the image height, as in the lab.
  std::optional<double> vertical_fov_degrees;
  std::optional<float> focal_length_px;
  // The built-in scenes' camera is the lab's orbit camera, Camera(width, height, yaw, distance),
  // whose rays the lab's images depend on bit for bit; position (0, 0, -distance), look_at and up
  // then only describe it. Scene files and meshes are built with Camera::look_at.
  bool lab_orbit = false;
  // The image's x axis runs opposite to Camera::look_at's cross(forward, up): pbrt's camera, whose
  // +x is cross(up, forward) (scene/io/pbrt_scene.h). The camera is built mirrored.
  bool mirror_x = false;
  // A thin lens (Camera::with_lens): the aperture's radius in world units (0: a pinhole) and the
  // distance along the view direction of the plane in focus; without one, the distance from
  // position to look_at.
  float aperture_radius = 0.0f;
  std::optional<float> focus_distance;
  // An orthographic camera that shows 2 * ortho_half_height world units from the image's top to
  // its bottom (glTF's ymag); the field of view settings then do not apply.
  std::optional<float> ortho_half_height;
};

// A camera a file holds (glTF's), for `tritrace info` and --camera: its index in scene-graph
// order, its name (the node's, else the camera's, else empty) and what it is.
struct FileCamera {
  std::string name;
  std::string description;  // "perspective, yfov 0.7 rad (40.1 degrees), aspect 1.5" ...
};

// Command-line values that replace the scene's own (see docs/SCENE_FORMAT.md).
struct SceneOverrides {
  std::optional<int> width;
  std::optional<int> height;
  std::optional<double> yaw;       // orbit about the vertical through look_at, radians
  std::optional<float> distance;   // from the camera to look_at, along its line of sight; > 0
  std::optional<glm::vec3> light;  // position of the first light
  std::optional<float> aperture;   // the lens radius, >= 0 (0: a pinhole)
  std::optional<float> focus;      // the distance of the plane in focus, > 0
  // Which of a file's cameras (FileCamera): an index in scene-graph order or a name; read when
  // the file is loaded, not by apply_overrides. Empty: the first.
  std::string camera;
};

struct LoadStats {
  size_t meshes = 0;              // mesh sources (files, inline meshes, generators) and file meshes
  size_t dropped_degenerate = 0;  // zero-area triangles
  size_t dropped_non_finite = 0;  // triangles with a NaN or infinite vertex, or that overflow
};

struct LoadedScene {
  Scene scene;
  IntegratorSpec integrator;
  CameraSpec camera;  // the scene's own camera, before overrides: scene.camera is built from both
  LoadStats stats;
  std::string output;  // the scene file's output path; empty when it names none
  // What the loader skipped or approximated, one line per kind ("FILE:LINE: warning: what"), for
  // the front ends to print after "tritrace: " (pbrt-v4 files; empty for the others).
  std::vector<std::string> warnings;
  // The file's own cameras in scene-graph order (glTF's; empty for other files), and the one
  // `camera` was made from (-1: none of them, the framing on the bounds).
  std::vector<FileCamera> cameras;
  int camera_index = -1;
};

}  // namespace tritrace
