// glTF 2.0 cameras, read from the file's JSON (a .gltf, or a .glb's JSON chunk) rather than through
// assimp, which keeps yfov only as yfov * aspectRatio and names a camera after one of the nodes
// that use it: the cameras in scene-graph order with their node's world transform, and the choice
// among them that --camera makes.
#pragma once

#include <cstddef>
#include <glm/mat4x4.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tritrace/math/bounds.h"
#include "tritrace/scene/io/gltf_lights.h"  // is_gltf_file
#include "tritrace/scene/io/loaded_scene.h"

namespace tritrace {

struct GltfCamera {
  std::string name;  // the node's name, else the camera's, else empty
  bool orthographic = false;
  double yfov = 0.0;                   // perspective: the vertical field of view, radians
  std::optional<double> aspect_ratio;  // perspective: width / height, when the file gives it
  double xmag = 0.0, ymag = 0.0;       // orthographic: half the view's width and height
  glm::dmat4 world{1.0};               // the node's world transform (the camera looks along -z)
};

// The cameras of the file's scene (its "scene", else the first; without scenes, every root node)
// in scene-graph order: depth first, a node before its children, children in the order listed. A
// node met twice (a cycle, which glTF forbids) is not visited again. Throws Error(path, reason)
// when the JSON cannot be read or a camera or node is malformed.
std::vector<GltfCamera> read_gltf_cameras(const std::string& path);

// One line for `tritrace info`: "perspective, yfov 0.7 rad (40.1 deg), aspect 1"...
std::string describe(const GltfCamera& camera);

// The camera `selection` names: empty for the first, a whole number for that index, else the
// first camera whose name is the selection. Throws Error("--camera", reason, kUsage) when there
// is none (naming what the file has).
size_t choose_camera(const std::vector<GltfCamera>& cameras, const std::string& selection,
                     const std::string& path);

// Sets the view of `spec` (position, look_at, up, field of view or orthographic height, mirror) to
// `camera`'s. glTF has no target: look_at is put on the view axis at the depth of the centre of
// `bounds` (where a lens focuses by default and what --yaw orbits about), or one unit ahead when
// that centre is not in front. The node's scale is ignored, as Blender's importer ignores it.
void set_gltf_view(const GltfCamera& camera, const Bounds3& bounds, CameraSpec* spec);

}  // namespace tritrace
