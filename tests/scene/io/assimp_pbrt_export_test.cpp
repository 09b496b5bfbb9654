// pbrt-v4 files that tritrace did not write: Debian's assimp-utils exports a glTF test model
// (tests/data/gltf/room.gltf) with `assimp export room.gltf room.pbrt`, and tritrace renders both
// files alike. The exporter's camera and lights are not the glTF's (docs/SCENE_FORMAT.md says
// why), so both scenes get the glTF's camera and one white environment before rendering: what is
// compared is the geometry, its transforms and the materials as each loader maps them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "tritrace/accel/make_accel.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

const std::string kRoom = std::string(TRITRACE_SOURCE_DIR) + "/tests/data/gltf/room.gltf";

// The glTF's camera, at 64 x 64 pixels, and a white environment as the only light.
void same_view_and_light(Scene& scene, const Camera& view) {
  constexpr int kSide = 64;
  scene.camera = Camera::look_at(kSide, kSide, view.position(), view.position() + view.forward(),
                                 -view.down(), view.focal_px() * kSide / view.height());
  scene.lights.clear();
  scene.spot_lights.clear();
  scene.directional_lights.clear();
  scene.environment_map.reset();
  scene.environment = glm::vec3(1.0f);
}

glm::dvec3 mean(const Image& image) {
  glm::dvec3 sum(0.0);
  for (const glm::vec3& p : image.pixels()) sum += glm::dvec3(p);
  return sum / static_cast<double>(image.pixels().size());
}

Image render_path(const Scene& scene) {
  const auto accel = make_accel(AccelKind::kBvh, scene, kDefaultKernel);
  return render(scene, *accel, PathIntegrator(scene), {.spp = 32, .seed = 4});
}

TEST(AssimpPbrtExport, ExportedRoomRendersLikeTheGltf) {
  if (std::system("command -v assimp >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "the assimp command (Debian's assimp-utils) is not installed; "
                    "scripts/install-deps.sh installs it";
  }
  const fs::path dir =
      fs::temp_directory_path() / ("tritrace-assimp-export-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string command =
      "cd '" + dir.string() + "' && assimp export '" + kRoom + "' room.pbrt > export.log 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << "assimp export failed: see " << dir / "export.log";
  LoadedScene gltf = load_scene(kRoom);
  LoadedScene pbrt = load_scene((dir / "room.pbrt").string());
  fs::remove_all(dir);
  EXPECT_EQ(pbrt.scene.mesh.size(), gltf.scene.mesh.size());
  const Camera view = gltf.scene.camera;
  same_view_and_light(gltf.scene, view);
  same_view_and_light(pbrt.scene, view);
  const glm::dvec3 want = mean(render_path(gltf.scene));
  const glm::dvec3 got = mean(render_path(pbrt.scene));
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(got[c] / want[c], 1.0, 0.02)
        << "channel " << c << ": pbrt " << got[c] << ", glTF " << want[c];
  }
}

}  // namespace
}  // namespace tritrace
