// The one entry point front ends use to turn a file into a Scene: .json files are scene files,
// .pbrt files pbrt-v4 scenes (pbrt_scene.h), anything else is a mesh for assimp, rendered with
// defaults framed on its bounds.
#pragma once

#include <string>

#include "tritrace/scene/io/gltf_lights.h"
#include "tritrace/scene/io/loaded_scene.h"
#include "tritrace/scene/io/mesh_import.h"

namespace tritrace {

// Vertical field of view of the camera framed on an imported mesh.
inline constexpr double kFramingFovDegrees = 40.0;
// The framed mesh's nearest surface receives about this much direct light (before the cosine),
// so that with the lab's ambient 0.5 and a grey albedo the image is neither black nor clipped.
inline constexpr float kFramingIrradiance = 0.8f;
// A framed mesh's environment under the path integrator: uniform grey radiance, a soft fill that
// gives an unoccluded surface irradiance pi * 0.25 = 0.79, about the key light's, so that shadows
// are soft and no side is black (a product shot, not a model in the void). The lab integrator
// ignores it and keeps the lab's ambient term.
inline constexpr float kDefaultEnvironmentRadiance = 0.25f;

// Builds scene.camera from the camera description with `overrides` applied, and moves the first
// light (adding one with the lab's power if there is none). loaded.camera is left as it was, so
// calling it again with other view overrides gives the scene that loading with them would have
// given, bit for bit: how the viewer changes the view without loading the geometry again. Throws
// Error naming the flag when the result is not a valid camera.
void apply_overrides(LoadedScene& loaded, const SceneOverrides& overrides);

bool is_scene_file(const std::string& path);  // by extension: .json, any case

// Loads a scene file or a mesh file and applies `overrides`. Throws Error(file, reason).
LoadedScene load_scene(const std::string& path, const SceneOverrides& overrides = {});

// A built-in scene by name (make_builtin_scene: "cornell", "terrain:1m" ...) as a LoadedScene,
// with the same overrides. Throws Error(name, reason, kUsage) for an unknown name.
LoadedScene load_builtin_scene(const std::string& name, const SceneOverrides& overrides = {});

// A scene holding an imported mesh with the defaults: a camera framed on its bounds (y up, as
// most mesh formats have it) and the lab's ambient term, lit by the file's own `lights` (a glTF's
// punctual lights) or, when it has none, by a point light near the camera and a grey environment.
LoadedScene scene_from_mesh(const ImportedMesh& mesh, const SceneOverrides& overrides = {},
                            const PunctualLights& lights = {});

}  // namespace tritrace
