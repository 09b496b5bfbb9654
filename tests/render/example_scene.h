// The repository's example scene files (scenes/*.json) loaded at a given image size, for the
// render tests that check integrators on them.
#pragma once

#include <string>

#include "tritrace/scene/io/scene_loader.h"

namespace tritrace::testing_scenes {

// scenes/<file> rendered at width x height (the file's own camera, its film resized).
inline Scene example_scene(const std::string& file, int width, int height) {
  SceneOverrides size;
  size.width = width;
  size.height = height;
  return load_scene(std::string(TRITRACE_SOURCE_DIR) + "/scenes/" + file, size).scene;
}

// The same at side x side.
inline Scene example_scene(const std::string& file, int side) {
  return example_scene(file, side, side);
}

}  // namespace tritrace::testing_scenes
