// Load, then render tiny, so that whatever the loaders let through also meets the camera, the
// accelerator and the integrator; images (HDR, EXR) are only decoded.
#include "fuzz_entries.h"

#include <array>
#include <span>
#include <string>
#include <string_view>

#include "tritrace/accel/brute_force.h"
#include "tritrace/distributed/film_merger.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/pbrt_scene.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace::fuzz {
namespace {

constexpr int kSide = 8;

// Small enough to stay fast with the brute-force accelerator.
constexpr size_t kMaxRenderedTriangles = 20000;

void render_tiny(const Scene& scene) {
  if (scene.mesh.size() > kMaxRenderedTriangles) return;
  const BruteForceAccel accel(scene.mesh, kDefaultKernel);
  RenderOptions options;
  options.threads = 1;
  const Image image = render(scene, accel, LabIntegrator(), options);
  (void)image;
}

ImportedMesh fixed_mesh(const std::string&) {
  ImportedMesh m;
  m.corners = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}};
  m.material = {0, 0};
  m.materials = {{kNeutralGrey}};
  m.material_names = {"fixed"};
  m.meshes = 1;
  return m;
}

}  // namespace

void scene_json_one_input(const uint8_t* data, size_t size) {
  try {
    SceneFileOptions options;
    options.read_mesh = fixed_mesh;
    LoadedScene loaded = parse_scene_json(
        std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.json", options);
    SceneOverrides small;
    small.width = kSide;
    small.height = kSide;
    apply_overrides(loaded, small);
    render_tiny(loaded.scene);
  } catch (const Error&) {
  }
}

void pbrt_scene_one_input(const uint8_t* data, size_t size) {
  try {
    PbrtOptions options;
    options.read_text = [](const std::string& path) -> std::string {
      throw Error(path, "not read by the fuzzer");
    };
    options.read_mesh = fixed_mesh;
    options.read_images = false;
    LoadedScene loaded = parse_pbrt_scene(
        std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.pbrt", options);
    SceneOverrides small;
    small.width = kSide;
    small.height = kSide;
    apply_overrides(loaded, small);
    render_tiny(loaded.scene);
  } catch (const Error&) {
  }
}

void mesh_memory_one_input(const uint8_t* data, size_t size, bool isolate_assimp) {
  static constexpr std::array<const char*, 10> kHints = {"obj", "ply", "stl", "gltf", "glb",
                                                         "off", "dae", "3ds", "fbx",  "x"};
  if (size < 1) return;
  const std::string hint = kHints[data[0] % kHints.size()];
  try {
    const std::span<const uint8_t> bytes(data + 1, size - 1);
    // Under libFuzzer assimp must run in this process, where coverage is counted; the replay
    // (and tritrace itself) goes through the isolated importer, which turns assimp's crashes into
    // errors.
    const ImportedMesh mesh = isolate_assimp
                                  ? import_mesh_memory(bytes, hint, "fuzz." + hint)
                                  : import_mesh_memory_in_process(bytes, hint, "fuzz." + hint);
    SceneOverrides small;
    small.width = kSide;
    small.height = kSide;
    render_tiny(scene_from_mesh(mesh, small).scene);
  } catch (const Error&) {
  }
}

void hdr_image_one_input(const uint8_t* data, size_t size) {
  try {
    (void)decode_radiance_hdr(std::span(data, size), "fuzz.hdr");
  } catch (const Error&) {
  }
}

void exr_image_one_input(const uint8_t* data, size_t size) {
  try {
    (void)decode_exr_image(std::span(data, size), "fuzz.exr");
  } catch (const Error&) {
  }
}

void partial_film_one_input(const uint8_t* data, size_t size) {
  try {
    PartialFilm part = decode_partial_film(std::span(data, size), "fuzz.exr");
    const RenderIdentity& r = part.info.render;
    if (static_cast<size_t>(r.width) * static_cast<size_t>(r.height) > size_t{256} * 256) return;
    FilmMerger merger(r, part.info.range.tiles);
    merger.add(part.info.range, std::move(part.film));
    if (merger.complete()) (void)std::move(merger).finish().resolve();
  } catch (const Error&) {
  }
}

}  // namespace tritrace::fuzz
