// Moving a scene by a similarity: vertices, lights and camera move alike, light power scales by
// scale^2, and the camera keeps its orientation.
#include "tritrace/scene/transform.h"

#include <gtest/gtest.h>

#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

TEST(Transformed, MovesVerticesLightAndCameraAndScalesPower) {
  const Scene base = make_cornell_box();
  const Similarity xf{2.0f, {10.0f, -4.0f, 0.5f}};
  const Scene s = transformed(base, xf);
  ASSERT_EQ(s.mesh.size(), base.mesh.size());
  // Triangle 0's first corner is the floor corner C = (-1, 1, 1): 2 * C + t.
  EXPECT_EQ(s.mesh.vertex(0, 0), glm::vec3(8.0f, -2.0f, 2.5f));
  for (size_t i = 0; i < s.mesh.size(); ++i) {
    EXPECT_EQ(s.mesh.material()[i], base.mesh.material()[i]);
    // Only up to rounding: adding t rounds the block corners.
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.mesh.normal()[i][c], base.mesh.normal()[i][c], 1e-5f);
  }
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].position, glm::vec3(10.0f, -5.0f, -0.9f));  // 2 * (0, -0.5, -0.7) + t
  EXPECT_EQ(s.lights[0].power, glm::vec3(56.0f));                   // 14 * 2^2
  EXPECT_EQ(s.ambient, base.ambient);
  EXPECT_EQ(s.camera.position(), glm::vec3(10.0f, -4.0f, -5.5f));  // 2 * (0, 0, -3) + t
  EXPECT_EQ(s.camera.primary_ray(17, 333).dir, base.camera.primary_ray(17, 333).dir);
  EXPECT_EQ(s.camera.width(), 500);
  EXPECT_EQ(s.camera.focal_px(), 500.0f);
}

}  // namespace
}  // namespace tritrace
