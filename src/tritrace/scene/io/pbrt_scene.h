// pbrt-v4 scene files (.pbrt): the directives, graphics state and transforms of pbrt's format
// interpreted and mapped to tritrace's objects (docs/SCENE_FORMAT.md, "pbrt-v4 scene files", has
// the table of what is supported, approximated and skipped). Errors name "FILE:LINE:COL"; what
// tritrace cannot render is skipped with one warning per kind, naming where it first appears.
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include "tritrace/scene/io/loaded_scene.h"
#include "tritrace/scene/io/mesh_import.h"

namespace tritrace {

struct PbrtOptions {
  // Reads a file a scene includes or names (Include, Import), given its resolved path. Defaults
  // to read_input_file; tests replace it.
  std::function<std::string(const std::string& path)> read_text;
  // Reads a "plymesh" file. Defaults to import_mesh_file (the native PLY reader, else assimp).
  std::function<ImportedMesh(const std::string& path)> read_mesh;
  // Whether image files (imagemap textures, infinite lights' maps) are read; when false, naming
  // one is an error (the fuzzer keeps inputs away from the disk).
  bool read_images = true;
};

// Whether a path names a pbrt-v4 scene file: the extension .pbrt, any case.
bool is_pbrt_file(const std::string& path);

// Interprets pbrt scene text. `path` names it in messages; relative file names in it are resolved
// against the folder of the file that names them, then against the folder of `path` (pbrt's
// search directory). The camera is described in the result (LoadedScene::camera), not built.
// Throws Error("FILE:LINE:COL", reason) for a malformed file.
LoadedScene parse_pbrt_scene(std::string_view text, const std::string& path,
                             const PbrtOptions& options = {});

// Reads and interprets a .pbrt file.
LoadedScene load_pbrt_scene(const std::string& path, const PbrtOptions& options = {});

}  // namespace tritrace
