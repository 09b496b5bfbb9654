// What users run, with default settings: the lab image has no pixel where the camera ray slipped
// between two triangles of the room (every ray of the default view meets the room, so a black
// pixel is a leak: shadowed surfaces still get the ambient term), at every size; and the accels
// tritrace implements write byte-identical images for any size, yaw, distance and light position.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <random>

#include "tritrace/accel/make_accel.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

class DefaultLabImage : public ::testing::TestWithParam<int> {};

TEST_P(DefaultLabImage, NoRaySlipsThroughTheRoom) {
  const int side = GetParam();
  const Scene scene = make_cornell_box({.width = side, .height = side});
  const AccelKind kind = AccelKind::kBvh;  // the default accel, with its default kernel
  const std::unique_ptr<Accel> accel = make_accel(kind, scene.mesh, default_kernel_for(kind));
  const Image image = render(scene, *accel, LabIntegrator{}, {});
  int black = 0;
  for (const glm::vec3& p : image.pixels()) black += p == glm::vec3(0.0f);
  EXPECT_EQ(black, 0) << side << " x " << side;
}

// 500: the lab's size, where Möller–Trumbore leaves three black pixels on the floor's diagonal;
// the others spread over 16 to 4096.
INSTANTIATE_TEST_SUITE_P(Sizes, DefaultLabImage,
                         ::testing::Values(16, 97, 500, 777, 1024, 2048, 4096));

// Möller–Trumbore, for contrast: the seam leaks at the lab's size (the test above can fail).
TEST(DefaultLabImage, MollerTrumboreLeaksAtTheLabSize) {
  const Scene scene = make_cornell_box();
  const std::unique_ptr<Accel> accel =
      make_accel(AccelKind::kBvh, scene.mesh, Kernel::kMollerTrumbore);
  const Image image = render(scene, *accel, LabIntegrator{}, {});
  int black = 0;
  for (const glm::vec3& p : image.pixels()) black += p == glm::vec3(0.0f);
  EXPECT_GT(black, 0);
}

bool same_bits(const Image& a, const Image& b) {
  return a.pixels().size() == b.pixels().size() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)) ==
             0;
}

TEST(DefaultAccels, WriteByteIdenticalImagesForAnyView) {
  std::mt19937 rng(17);
  std::uniform_int_distribution<int> size(8, 160);
  std::uniform_real_distribution<float> yaw(-3.2f, 3.2f), distance(0.3f, 40.0f), pos(-0.95f, 0.95f);
  for (const char* name : {"cornell", "terrain:2k"}) {
    const Scene base = make_builtin_scene(name);
    std::unique_ptr<Accel> accels[3];
    const AccelKind kinds[3] = {AccelKind::kBrute, AccelKind::kBvh, AccelKind::kBvhSingle};
    for (int k = 0; k < 3; ++k) {
      accels[k] = make_accel(kinds[k], base.mesh, default_kernel_for(kinds[k]));
    }
    for (int view = 0; view < 6; ++view) {
      Scene scene = base;
      const int w = size(rng), h = size(rng);
      scene.camera = Camera(w, h, yaw(rng), distance(rng));
      scene.lights.front().position = {pos(rng), pos(rng), pos(rng)};
      const Image brute = render(scene, *accels[0], LabIntegrator{}, {});
      EXPECT_TRUE(same_bits(brute, render(scene, *accels[1], LabIntegrator{}, {})))
          << name << " view " << view << ": bvh";
      EXPECT_TRUE(same_bits(brute, render(scene, *accels[2], LabIntegrator{}, {})))
          << name << " view " << view << ": bvh-single";
    }
  }
}

}  // namespace
}  // namespace tritrace
