// Imported meshes under the path tracer are two-sided: a mesh whose winding is reversed renders as
// the original (reflection and emission alike), while the lab integrator keeps the lab's one-sided
// rule (a back face gets the ambient term only).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

class Winding : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() /
        ("tritrace-winding-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
         "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    // A tilted quad facing the camera (counter-clockwise seen from -z) and the same quad wound
    // the other way, each with a diffuse and an emissive material from its MTL file.
    const std::string v = "v -1 -1 0.3\nv 1 -1 -0.3\nv 1 1 -0.3\nv -1 1 0.3\n";
    std::ofstream(dir_ / "m.mtl")
        << "newmtl grey\nKd 0.7 0.6 0.5\nnewmtl glow\nKd 0 0 0\nKe 2 3 4\n";
    for (const char* mtl : {"grey", "glow"}) {
      std::ofstream(dir_ / (std::string(mtl) + "_front.obj"))
          << "mtllib m.mtl\n"
          << v << "usemtl " << mtl << "\nf 1 4 3\nf 1 3 2\n";
      std::ofstream(dir_ / (std::string(mtl) + "_back.obj"))
          << "mtllib m.mtl\n"
          << v << "usemtl " << mtl << "\nf 1 3 4\nf 1 2 3\n";
    }
  }
  void TearDown() override { fs::remove_all(dir_); }

  Scene scene(const std::string& file) const {
    const std::string text = R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0],
        "up": [0, -1, 0], "vertical_fov": 30, "width": 24, "height": 24},
        "lights": [{"position": [0.5, -0.5, -2], "power": [30, 30, 30]}],
        "ambient": [0.1, 0.1, 0.1], "meshes": [{"file": ")" +
                             file + R"("}]})";
    LoadedScene loaded = parse_scene_json(text, (dir_ / "scene.json").string());
    apply_overrides(loaded, {});
    return std::move(loaded.scene);
  }

  fs::path dir_;
};

Image render_path(const Scene& scene, int max_depth) {
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene, PathSettings{.max_depth = max_depth});
  return render(scene, accel, integrator, {.spp = 8, .seed = 9});
}

TEST_F(Winding, ReversedMeshReflectsAsTheOriginalUnderPath) {
  const Scene front = scene("grey_front.obj"), back = scene("grey_back.obj");
  ASSERT_LT(glm::dot(front.mesh.normal()[0], back.mesh.normal()[0]), 0.0f) << "windings differ";
  const Image a = render_path(front, 1), b = render_path(back, 1);
  int lit = 0;
  for (size_t i = 0; i < a.pixels().size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(a.pixels()[i][c], b.pixels()[i][c], 1e-4f * (1.0f + a.pixels()[i][c])) << i;
    }
    lit += a.pixels()[i].x > 0.01f;
  }
  EXPECT_GT(lit, 100);
}

TEST_F(Winding, ReversedMeshEmitsAsTheOriginalUnderPath) {
  for (const char* file : {"glow_front.obj", "glow_back.obj"}) {
    const Scene s = scene(file);
    EXPECT_TRUE(s.materials[0].two_sided) << file;
    const Image image = render_path(s, 0);
    EXPECT_EQ(image.at(12, 12), glm::vec3(2, 3, 4)) << file;  // the quad's middle: its emission
  }
}

TEST_F(Winding, LabIntegratorKeepsTheOneSidedRule) {
  const Scene front = scene("grey_front.obj"), back = scene("grey_back.obj");
  const BvhAccel front_accel(front.mesh, kDefaultKernel), back_accel(back.mesh, kDefaultKernel);
  const LabIntegrator lab;
  const Image a = render(front, front_accel, lab, {});
  const Image b = render(back, back_accel, lab, {});
  // The lab shades albedo * (direct + ambient) on the front, and albedo * ambient alone behind.
  const glm::vec3 ambient_only = glm::vec3(0.7f, 0.6f, 0.5f) * 0.1f;
  EXPECT_GT(a.at(12, 12).x, 2.0f * ambient_only.x);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.at(12, 12)[c], ambient_only[c], 1e-6f);
}

}  // namespace
}  // namespace tritrace
