// The lab camera: position R_y(yaw)(0,0,-3), pixel (x, y) looking along R_y(yaw)(x - W/2, y - H/2,
// H) with integer W/2 and H/2, rows growing downward.
#include "tritrace/scene/camera.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <glm/glm.hpp>
#include <numbers>
#include <vector>

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

// primary_rays (SIMD where the build has it) against primary_ray, the scalar reference: every
// field bit for bit, for rectangles of every shape the renderer uses (4 x 4 blocks, cut blocks at
// image edges) and odd ones, for orbit and look-at cameras.
void expect_same_rays(const Camera& cam, int x0, int y0, int x1, int y1) {
  std::vector<Ray> rays(static_cast<size_t>((x1 - x0) * (y1 - y0)));
  cam.primary_rays(x0, y0, x1, y1, rays.data());
  size_t i = 0;
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x, ++i) {
      const Ray want = cam.primary_ray(x, y);
      const float got_f[8] = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z, rays[i].dir.x,
                              rays[i].dir.y,    rays[i].dir.z,    rays[i].tmin,     rays[i].tmax};
      const float want_f[8] = {want.origin.x, want.origin.y, want.origin.z, want.dir.x,
                               want.dir.y,    want.dir.z,    want.tmin,     want.tmax};
      for (int f = 0; f < 8; ++f) {
        ASSERT_EQ(std::bit_cast<uint32_t>(got_f[f]), std::bit_cast<uint32_t>(want_f[f]))
            << "pixel (" << x << ", " << y << ") field " << f << " of rect [" << x0 << ", " << x1
            << ") x [" << y0 << ", " << y1 << ")";
      }
    }
  }
}

TEST(Camera, BlockRaysEqualPrimaryRayBitForBit) {
  const Camera cameras[] = {
      Camera(500, 500), Camera(1280, 720, 0.35), Camera(333, 97, -2.5, 7.25f, 123.5f),
      Camera::look_at(640, 480, {1.5f, -0.25f, -4.0f}, {0.1f, 0.2f, 0.3f}, {0.0f, -1.0f, 0.0f},
                      Camera::focal_for_vertical_fov(480, 50.0))};
  for (const Camera& cam : cameras) {
    const int w = cam.width(), h = cam.height();
    for (int y = 0; y < h; y += 4) {
      for (int x = 0; x < w; x += 4) {
        expect_same_rays(cam, x, y, std::min(x + 4, w), std::min(y + 4, h));
      }
    }
    expect_same_rays(cam, 0, 0, 1, 1);
    expect_same_rays(cam, 3, 2, 8, 9);   // 5 x 7: lanes wrap across rows
    expect_same_rays(cam, 0, 1, w, 3);   // whole rows
    expect_same_rays(cam, 1, 0, 18, 1);  // 17 pixels in one row
  }
}

TEST(Camera, LensRayWithoutALensIsThePinholeRayBitForBit) {
  const Camera cam = Camera(333, 97, -2.5, 7.25f, 123.5f).with_lens(0.0f, 3.0f);
  for (const glm::vec2 u : {glm::vec2(0.0f), glm::vec2(0.25f, 0.9f), glm::vec2(0.999f)}) {
    const Ray a = cam.lens_ray(17.25f, 40.5f, u), b = cam.ray_through(17.25f, 40.5f);
    EXPECT_EQ(a.origin, b.origin);
    EXPECT_EQ(a.dir, b.dir);
  }
}

TEST(Camera, LensRaysLeaveTheLensDiskAndMeetInThePlaneOfFocus) {
  // Camera at (0, 0, -3) looking along +z, right +x, down +y; lens radius 0.2, focus at 5. The
  // pinhole ray through image position (400, 100) of a 500 x 500 image (f = 500) has direction
  // (150, -150, 500): it meets the plane z = -3 + 5 at (1.5, -1.5, 2).
  const Camera cam = Camera(500, 500).with_lens(0.2f, 5.0f);
  const glm::vec3 focus_point(1.5f, -1.5f, 2.0f);
  for (const glm::vec2 u : {glm::vec2(0.5f), glm::vec2(0.0f), glm::vec2(0.99f, 0.1f),
                            glm::vec2(0.3f, 0.7f), glm::vec2(1.0f, 0.5f)}) {
    const Ray r = cam.lens_ray(400.0f, 100.0f, u);
    // On the lens: the plane z = -3, within the radius.
    EXPECT_FLOAT_EQ(r.origin.z, -3.0f);
    EXPECT_LE(std::hypot(r.origin.x, r.origin.y), 0.2f * (1.0f + 1e-6f));
    EXPECT_NEAR(glm::length(r.dir), 1.0f, 1e-6f);
    const float t = (focus_point.z - r.origin.z) / r.dir.z;
    const glm::vec3 at = r.origin + t * r.dir;
    EXPECT_NEAR(at.x, focus_point.x, 1e-5f);
    EXPECT_NEAR(at.y, focus_point.y, 1e-5f);
  }
  // u = (1, 1/2) is the disk's rightmost point (the concentric map's +x axis).
  const Ray edge = cam.lens_ray(400.0f, 100.0f, glm::vec2(1.0f, 0.5f));
  EXPECT_NEAR(edge.origin.x, 0.2f, 1e-6f);
  EXPECT_NEAR(edge.origin.y, 0.0f, 1e-6f);
}

TEST(Camera, OrthographicRaysAreParallelFromTheImagePlane) {
  // 200 x 100 pixels, 0.01 units per pixel: the view is 2 x 1 units about the camera's axis.
  const Camera cam =
      Camera::look_at(200, 100, {1.0f, 2.0f, 3.0f}, {1.0f, 2.0f, 10.0f}, {0.0f, -1.0f, 0.0f}, 0.0f)
          .orthographic(0.01f);
  EXPECT_TRUE(cam.is_orthographic());
  const Ray corner = cam.ray_through(0.0f, 0.0f);
  EXPECT_EQ(corner.dir, glm::vec3(0.0f, 0.0f, 1.0f));
  EXPECT_NEAR(corner.origin.x, 1.0f - 1.0f, 1e-6f);
  EXPECT_NEAR(corner.origin.y, 2.0f - 0.5f, 1e-6f);
  EXPECT_EQ(corner.origin.z, 3.0f);
  const Ray r = cam.primary_ray(150, 75);  // 50 right, 25 down of the centre
  EXPECT_NEAR(r.origin.x, 1.5f, 1e-6f);
  EXPECT_NEAR(r.origin.y, 2.25f, 1e-6f);
  EXPECT_EQ(r.dir, glm::vec3(0.0f, 0.0f, 1.0f));
  // The batch form gives the same rays.
  std::vector<Ray> rays(16);
  cam.primary_rays(148, 74, 152, 78, rays.data());
  EXPECT_EQ(rays[4 + 2].origin, r.origin);
  EXPECT_EQ(rays[4 + 2].dir, r.dir);
}

}  // namespace
}  // namespace tritrace
