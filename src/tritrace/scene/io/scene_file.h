// JSON scene files (docs/SCENE_FORMAT.md): camera, lights, ambient, materials, meshes from files,
// inline triangles or generators, and output settings. Every mistake in a file is an Error naming
// the file, the JSON location and the rule broken.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "tritrace/scene/io/loaded_scene.h"
#include "tritrace/scene/io/mesh_import.h"

namespace tritrace {

struct SceneFileOptions {
  // Reads a mesh file a scene refers to, given its path resolved against the scene's folder.
  // Defaults to import_mesh_file; the fuzzer replaces it so that inputs cannot reach the disk.
  std::function<ImportedMesh(const std::string& path)> read_mesh;
};

// Parses scene text. `path` names the file in messages and is the folder mesh files are resolved
// against. The camera is described in the result but not built: call apply_camera.
LoadedScene parse_scene_json(std::string_view text, const std::string& path,
                             const SceneFileOptions& options = {});

// Levenshtein edit distance, for "did you mean" suggestions.
size_t edit_distance(std::string_view a, std::string_view b);

}  // namespace tritrace
