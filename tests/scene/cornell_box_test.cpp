// The built-in Cornell box against the fact sheet: 30 triangles, colours by index, the scaling to
// [-1, 1]^3 with x and y negated, and normals that face into the room and out of the blocks.
#include "tritrace/scene/cornell_box.h"

#include <gtest/gtest.h>

#include <glm/glm.hpp>

namespace tritrace {
namespace {

const glm::vec3 kRed(0.75f, 0.15f, 0.15f), kYellow(0.75f, 0.75f, 0.15f),
    kGreen(0.15f, 0.75f, 0.15f), kCyan(0.15f, 0.75f, 0.75f), kBlue(0.15f, 0.15f, 0.75f),
    kPurple(0.75f, 0.15f, 0.75f), kWhite(0.75f, 0.75f, 0.75f);

glm::vec3 albedo(const Scene& s, size_t tri) {
  return s.materials[s.mesh.material()[tri]].albedo;
}

void expect_vec_near(glm::vec3 got, glm::vec3 want, float tol = 1e-6f) {
  EXPECT_NEAR(got.x, want.x, tol);
  EXPECT_NEAR(got.y, want.y, tol);
  EXPECT_NEAR(got.z, want.z, tol);
}

TEST(CornellBox, HasThirtyTrianglesColouredAsTheFactSheet) {
  const Scene s = make_cornell_box();
  ASSERT_EQ(s.mesh.size(), 30u);
  const glm::vec3 room[10] = {kGreen,  kGreen, kPurple, kPurple, kYellow,
                              kYellow, kCyan,  kCyan,   kWhite,  kWhite};
  for (size_t i = 0; i < 10; ++i) EXPECT_EQ(albedo(s, i), room[i]) << "triangle " << i;
  for (size_t i = 10; i < 20; ++i) EXPECT_EQ(albedo(s, i), kRed) << "triangle " << i;
  for (size_t i = 20; i < 30; ++i) EXPECT_EQ(albedo(s, i), kBlue) << "triangle " << i;
}

TEST(CornellBox, RoomSpansTheUnitCubeWithYDown) {
  const Scene s = make_cornell_box();
  const Bounds3 b = s.mesh.bounds();
  expect_vec_near(b.lo, glm::vec3(-1.0f));
  expect_vec_near(b.hi, glm::vec3(1.0f));
  // Floor corner C = (L, 0, L) maps to (-1, 1, 1): x and y negated, z kept.
  expect_vec_near(s.mesh.vertex(0, 0), glm::vec3(-1.0f, 1.0f, 1.0f));
  // Floor triangles lie at y = +1, ceiling at y = -1, back wall at z = +1.
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(s.mesh.vertex(0, c).y, 1.0f, 1e-6f);
    EXPECT_NEAR(s.mesh.vertex(6, c).y, -1.0f, 1e-6f);
    EXPECT_NEAR(s.mesh.vertex(8, c).z, 1.0f, 1e-6f);
    EXPECT_NEAR(s.mesh.vertex(2, c).x, -1.0f, 1e-6f);  // purple wall
    EXPECT_NEAR(s.mesh.vertex(4, c).x, 1.0f, 1e-6f);   // yellow wall
  }
}

TEST(CornellBox, RoomNormalsPointIntoTheRoom) {
  const Scene s = make_cornell_box();
  const auto& n = s.mesh.normal();
  const glm::vec3 expected[5] = {{0, -1, 0}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, 0, -1}};
  for (int face = 0; face < 5; ++face) {
    expect_vec_near(n[2 * face], expected[face]);
    expect_vec_near(n[2 * face + 1], expected[face]);
  }
}

TEST(CornellBox, BlockTopsAtFactSheetHeights) {
  const Scene s = make_cornell_box();
  float short_top = 1.0f, tall_top = 1.0f;
  for (size_t i = 10; i < 30; ++i) {
    for (int c = 0; c < 3; ++c) {
      float& top = i < 20 ? short_top : tall_top;
      top = std::min(top, s.mesh.vertex(i, c).y);
    }
  }
  EXPECT_NEAR(short_top, 1.0f - 330.0f / 555.0f, 1e-6f);
  EXPECT_NEAR(tall_top, 1.0f - 660.0f / 555.0f, 1e-6f);
}

TEST(CornellBox, BlockNormalsPointOutward) {
  const Scene s = make_cornell_box();
  for (size_t block = 0; block < 2; ++block) {
    glm::vec3 centre(0.0f);
    for (size_t i = 10 + 10 * block; i < 20 + 10 * block; ++i) {
      for (int c = 0; c < 3; ++c) centre += s.mesh.vertex(i, c) / 30.0f;
    }
    for (size_t i = 10 + 10 * block; i < 20 + 10 * block; ++i) {
      const glm::vec3 mid =
          (s.mesh.vertex(i, 0) + s.mesh.vertex(i, 1) + s.mesh.vertex(i, 2)) / 3.0f;
      EXPECT_GT(glm::dot(s.mesh.normal()[i], mid - centre), 0.0f) << "triangle " << i;
      EXPECT_NEAR(glm::length(s.mesh.normal()[i]), 1.0f, 1e-6f);
    }
  }
}

TEST(CornellBox, LabLightAmbientAndCamera) {
  const Scene s = make_cornell_box();
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].position, glm::vec3(0.0f, -0.5f, -0.7f));
  EXPECT_EQ(s.lights[0].power, glm::vec3(14.0f));
  EXPECT_EQ(s.ambient, glm::vec3(0.5f));
  EXPECT_EQ(s.camera.width(), 500);
  EXPECT_EQ(s.camera.height(), 500);
  EXPECT_EQ(s.camera.position(), glm::vec3(0.0f, 0.0f, -3.0f));
}

}  // namespace
}  // namespace tritrace
