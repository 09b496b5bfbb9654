// The code the fuzzers run on one input, shared by the libFuzzer targets (TRITRACE_FUZZ) and by
// the regression test that replays every saved input in the normal build. Each returns normally
// for any input: an Error is an accepted outcome, a crash or sanitizer report is a bug.
#pragma once

#include <cstddef>
#include <cstdint>

namespace tritrace::fuzz {

// The bytes are a JSON scene file; "file" meshes resolve to a fixed small mesh, never the disk.
// A scene that loads is rendered at 8 x 8.
void scene_json_one_input(const uint8_t* data, size_t size);

// The bytes are a pbrt-v4 scene file; Include and Import fail, "plymesh" files resolve to a fixed
// small mesh and image files are refused, so nothing reaches the disk. A scene that loads is
// rendered at 8 x 8.
void pbrt_scene_one_input(const uint8_t* data, size_t size);

// The first byte picks the format hint given to assimp, the rest is the file; a mesh that imports
// becomes a scene with the default camera and light and is rendered at 8 x 8.
// isolate_assimp: import through the child-process importer, as tritrace does (the replay), or in
// this process, where libFuzzer sees assimp's coverage (the fuzzer).
void mesh_memory_one_input(const uint8_t* data, size_t size, bool isolate_assimp);

// The bytes are a Radiance HDR file, decoded as an environment map's file is.
void hdr_image_one_input(const uint8_t* data, size_t size);

// The bytes are an OpenEXR file, decoded as an environment map's file is.
void exr_image_one_input(const uint8_t* data, size_t size);

// The bytes are a partial film (render --spp-range / --tile); one that decodes is added to a
// merger of its render when the image is small.
void partial_film_one_input(const uint8_t* data, size_t size);

}  // namespace tritrace::fuzz
