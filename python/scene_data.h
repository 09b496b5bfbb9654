// What a tritrace.Scene holds, and the scene work of the Python module that needs no Python:
// loading through the CLI's loaders, building a scene from arrays as a mesh file would be, and the
// views (camera and light) that renders and camera rays ask for.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "tritrace/scene/io/loaded_scene.h"

namespace tritrace::python {

struct SceneData {
  // The scene as loaded. Its mesh never changes once built, so accels read it from any thread;
  // scene.camera and scene.lights are the view's only inside a ViewLock (below), and otherwise
  // the scene's own, kept in `camera` and `lights`.
  LoadedScene loaded;
  Camera camera;
  std::vector<PointLight> lights;
  std::string source;  // the file, the built-in scene's name, or "arrays"
  // Scene.from_arrays: the caller's index of each scene triangle, and its inverse (-1 for dropped
  // triangles), when triangles were dropped; empty when the two are the same.
  std::vector<uint32_t> caller_index;
  std::vector<int32_t> scene_index;
  size_t caller_triangles = 0;  // the indices hits report run over [0, caller_triangles)
  // Scene.from_arrays stores each triangle (a, b, c) as (a, c, b), as mesh files are stored, so
  // that the normal is the counter-clockwise one; hits then report u and v swapped back, as the
  // weights of the caller's b and c.
  bool caller_order_swapped = false;
  std::mutex view_mutex;
};

// Loads a scene file or mesh as `tritrace render FILE` does; throws Error(file, reason).
std::shared_ptr<SceneData> load_file(const std::string& path);
// A built-in scene by name; throws Error(name, reason, kUsage) for an unknown one.
std::shared_ptr<SceneData> load_builtin(const std::string& name);

// A scene of `triangles` (3 vertex indices each) over `vertices` (3 floats each), with one albedo
// per triangle (3 floats each), one for all (3 floats), or none (the neutral grey of mesh files),
// set up as a mesh file is: camera framed on its bounds, a point light near the camera, the lab's
// ambient term, the path tracer; each triangle (a, b, c) is stored as (a, c, b), as model files'
// counter-clockwise triangles are. Degenerate and non-finite triangles are dropped, as the
// loaders drop them, and counted in loaded.stats. Throws Error(argument name, reason, kUsage).
std::shared_ptr<SceneData> scene_from_arrays(std::span<const float> vertices,
                                             std::span<const int64_t> triangles,
                                             std::span<const float> albedo);

// The camera settings a scene file's camera has and the CLI's flags do not. Giving any of them to
// a built-in scene replaces the lab's orbit camera with a look-at camera.
struct CameraPose {
  std::optional<glm::vec3> position, look_at, up;
  std::optional<double> vertical_fov_degrees;
  std::optional<float> focal_length_px;
  bool any() const { return position || look_at || up || vertical_fov_degrees || focal_length_px; }
};

// The camera and lights of `data` with `pose` and then the CLI's `overrides` applied, exactly as
// loading a scene file with that camera and those flags would give them. Throws Error(argument
// name, reason, kUsage) for an invalid camera.
struct View {
  Camera camera;
  std::vector<PointLight> lights;
};
View make_view(const SceneData& data, const CameraPose& pose, const SceneOverrides& overrides);

// Puts `view` into data's scene for as long as it lives, holding data's view mutex (renders of one
// scene take turns; each uses every core), then puts the scene's own camera and lights back.
class ViewLock {
 public:
  ViewLock(SceneData& data, const View& view);
  ~ViewLock();
  ViewLock(const ViewLock&) = delete;
  ViewLock& operator=(const ViewLock&) = delete;
  const Scene& scene() const { return data_.loaded.scene; }

 private:
  SceneData& data_;
  std::lock_guard<std::mutex> lock_;
};

}  // namespace tritrace::python
