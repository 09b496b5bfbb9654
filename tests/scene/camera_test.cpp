// The lab camera: position R_y(yaw)(0,0,-3), pixel (x, y) looking along R_y(yaw)(x - W/2, y - H/2,
// H) with integer W/2 and H/2, rows growing downward.
#include "tritrace/scene/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/glm.hpp>
#include <numbers>

namespace tritrace {
namespace {

void expect_dir(glm::vec3 got, glm::vec3 unnormalised, float tol = 1e-6f) {
  const glm::vec3 want = unnormalised / std::sqrt(glm::dot(unnormalised, unnormalised));
  EXPECT_NEAR(got.x, want.x, tol);
  EXPECT_NEAR(got.y, want.y, tol);
  EXPECT_NEAR(got.z, want.z, tol);
}

TEST(Camera, CentrePixelLooksDownPlusZFromMinusThree) {
  const Camera cam(500, 500);
  const Ray r = cam.primary_ray(250, 250);
  EXPECT_EQ(r.origin, glm::vec3(0.0f, 0.0f, -3.0f));
  expect_dir(r.dir, {0.0f, 0.0f, 1.0f});
  EXPECT_EQ(r.tmin, 0.0f);
}

TEST(Camera, CornerPixelUsesPixelCornerAndFocalLengthHeight) {
  const Camera cam(500, 500);
  expect_dir(cam.primary_ray(0, 0).dir, {-250.0f, -250.0f, 500.0f});
  expect_dir(cam.primary_ray(499, 0).dir, {249.0f, -250.0f, 500.0f});
  // Row y grows downward, and world y points down: the bottom row looks toward +y.
  EXPECT_GT(cam.primary_ray(250, 499).dir.y, 0.0f);
}

TEST(Camera, NonSquareImageUsesIntegerHalvesAndHeightAsFocal) {
  const Camera cam(641, 481);  // W/2 = 320, H/2 = 240, f = 481
  expect_dir(cam.primary_ray(320, 240).dir, {0.0f, 0.0f, 1.0f});
  expect_dir(cam.primary_ray(0, 480).dir, {-320.0f, 240.0f, 481.0f});
}

TEST(Camera, YawOrbitsAboutYAndKeepsLookingAtTheCentre) {
  const double a = std::numbers::pi / 2;  // R_y(pi/2) maps (0,0,-3) to (-3,0,0)
  const Camera cam(500, 500, a);
  const Ray r = cam.primary_ray(250, 250);
  EXPECT_NEAR(r.origin.x, -3.0f, 1e-6f);
  EXPECT_NEAR(r.origin.y, 0.0f, 1e-6f);
  EXPECT_NEAR(r.origin.z, 0.0f, 1e-6f);
  expect_dir(r.dir, {1.0f, 0.0f, 0.0f});
}

TEST(Camera, SmallYawMatchesTheRotationMatrixByHand) {
  const double a = 0.05;  // one Left-arrow step in the lab
  const float c = static_cast<float>(std::cos(a)), s = static_cast<float>(std::sin(a));
  const Camera cam(500, 500, a);
  const Ray r = cam.primary_ray(100, 400);
  const glm::vec3 d(-150.0f, 150.0f, 500.0f);
  // Rows of R_y: (c, 0, s), (0, 1, 0), (-s, 0, c).
  expect_dir(r.dir, {c * d.x + s * d.z, d.y, -s * d.x + c * d.z});
  EXPECT_NEAR(r.origin.x, -3.0f * s, 1e-6f);
  EXPECT_NEAR(r.origin.z, -3.0f * c, 1e-6f);
}

TEST(Camera, WithPositionMovesTheCameraAndKeepsItsView) {
  const Camera cam(321, 123, 0.7);
  const Camera moved = cam.with_position({5.0f, 6.0f, 7.0f});
  EXPECT_EQ(moved.position(), glm::vec3(5.0f, 6.0f, 7.0f));
  EXPECT_EQ(moved.width(), 321);
  EXPECT_EQ(moved.focal_px(), cam.focal_px());
  for (int y : {0, 61, 122}) {
    for (int x : {0, 160, 320}) {
      EXPECT_EQ(moved.primary_ray(x, y).dir, cam.primary_ray(x, y).dir);
      EXPECT_EQ(moved.primary_ray(x, y).origin, glm::vec3(5.0f, 6.0f, 7.0f));
    }
  }
}

}  // namespace
}  // namespace tritrace
