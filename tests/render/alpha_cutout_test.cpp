// Cut-outs in rendered images: camera rays and shadow rays pass a mask's transparent texels, a
// blended surface lets 1 - alpha of the light through, and the image stays the same bit for bit
// for any thread count and tile size. Expected values by hand (alpha_scene.h).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "../accel/alpha_scene.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/render/lab_integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"

namespace tritrace {
namespace {

using alpha_test::kTransparentShare;

constexpr int kSide = 64;  // pixels: eight per texture column, so no pixel straddles a border

double mean_red(const Image& image) {
  double sum = 0.0;
  for (const glm::vec3& p : image.pixels()) sum += p.x;
  return sum / static_cast<double>(image.pixels().size());
}

bool same_bits(const Image& a, const Image& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (size_t k = 0; k < a.pixels().size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      if (std::bit_cast<uint32_t>(a.pixels()[k][c]) != std::bit_cast<uint32_t>(b.pixels()[k][c]))
        return false;
    }
  }
  return true;
}

// An orthographic camera whose 64 x 64 pixels cover [0, 1]^2 exactly, looking along +z from
// z = 0 (or, `floor`, along +y from y = 1.5 at the square [0, 1]^2 of x and z).
Camera square_camera(bool floor) {
  const Camera c = floor ? Camera::look_at(kSide, kSide, {0.5f, 1.5f, 0.5f}, {0.5f, 2.0f, 0.5f},
                                           {0.0f, 0.0f, -1.0f}, kSide)
                         : Camera::look_at(kSide, kSide, {0.5f, 0.5f, 0.0f}, {0.5f, 0.5f, 1.0f},
                                           {0.0f, -1.0f, 0.0f}, kSide);
  return c.orthographic(1.0f / kSide);
}

// Camera rays: a black masked quad before a glowing wall (radiance 1) shows the wall through
// exactly the transparent share of its area.
TEST(AlphaCutout, CameraSeesTheWallThroughTheTransparentShare) {
  Scene s = alpha_test::quad_before_wall(AlphaMode::kMask, true);
  s.materials[0].emission = glm::vec3(1.0f);
  s.materials[0].two_sided = true;
  s.materials[1].albedo = glm::vec3(0.0f);
  s.camera = square_camera(false);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const PathIntegrator pt(s, {.max_depth = 1});
  const Image image = render(s, *accel, pt, {.spp = 4, .seed = 3});
  EXPECT_NEAR(mean_red(image), kTransparentShare, 1e-6);
  // Embree's kernel is not tritrace's, but no camera ray here comes near an edge (the texture's
  // borders fall between samples), so it shows the same pixels: the same image, bit for bit.
  if (accel_available(AccelKind::kEmbree)) {
    const auto embree = make_accel(AccelKind::kEmbree, s, kDefaultKernel);
    EXPECT_TRUE(same_bits(image, render(s, *embree, pt, {.spp = 4, .seed = 3})));
  }
}

// The lab integrator's camera ray through each pixel's corner, x = k / 50 on the quad for column
// k of a 50-pixel orthographic view of [0, 1]^2: the wall shows where 2/8 < k / 50 < 5/8, which is
// k = 13 ... 31, 19 columns (no corner falls on a border). Lit by the ambient term only, each
// pixel is its surface's albedo times the ambient.
TEST(AlphaCutout, LabIntegratorSeesThroughTheMaskToo) {
  Scene s = alpha_test::quad_before_wall(AlphaMode::kMask, true);
  s.materials[0].albedo = glm::vec3(0.5f);
  s.materials[1].albedo = glm::vec3(0.25f);
  s.ambient = glm::vec3(1.0f);
  s.camera =
      Camera::look_at(50, 50, {0.5f, 0.5f, 0.0f}, {0.5f, 0.5f, 1.0f}, {0.0f, -1.0f, 0.0f}, 50)
          .orthographic(1.0f / 50);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const Image image = render(s, *accel, LabIntegrator(), {});
  for (int y = 0; y < 50; ++y) {
    for (int x = 0; x < 50; ++x) {
      const float u = s.camera.primary_ray(x, y).origin.x;
      const bool wall = u > 2.0f / 8 && u < 5.0f / 8;
      EXPECT_FLOAT_EQ(image.at(x, y).x, wall ? 0.5f : 0.25f) << x << ", " << y;
    }
  }
  int wall_columns = 0;
  for (int x = 0; x < 50; ++x) wall_columns += image.at(x, 25).x == 0.5f;
  EXPECT_EQ(wall_columns, 19);
}

// The scene for shadows: a floor (albedo 0.5) at y = 2 under a black quad at y = 1 with the
// column mask over [0, 1]^2 of x and z, lit straight down (+y) by a directional light of
// irradiance 1. The camera sits between them, so it sees only the floor, whose radiance is 0.5 / pi
// where the light reaches it.
Scene shadow_scene(AlphaMode mode, bool textured, float alpha) {
  Scene s;
  Material floor{glm::vec3(0.5f)};
  Material quad{glm::vec3(0.0f)};
  quad.alpha_mode = mode;
  quad.alpha = alpha;
  if (textured) {
    s.textures.push_back(alpha_test::column_texture());
    quad.albedo_texture = {0, WrapMode::kClamp, WrapMode::kClamp};
  }
  s.materials = {floor, quad};
  // The quad reaches half a unit beyond the view on every side (so that no shadow ray grazes its
  // edge), with texture coordinates u = x, v = z: the clamped texture is opaque out there.
  alpha_test::add_square(s.mesh, -0.5f, -0.5f, 2.0f, 1.0f, 1, 1, -0.5f, 1.5f);
  alpha_test::add_square(s.mesh, -2.0f, -2.0f, 5.0f, 2.0f, 0, 1);
  s.directional_lights.push_back({{0.0f, 1.0f, 0.0f}, glm::vec3(1.0f)});
  s.camera = square_camera(true);
  return s;
}

constexpr double kLitRadiance = 0.5 / std::numbers::pi;

TEST(AlphaCutout, MaskedShadowLetsThroughTheTransparentShare) {
  const Scene s = shadow_scene(AlphaMode::kMask, true, 1.0f);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const Image image = render(s, *accel, PathIntegrator(s), {.spp = 2, .seed = 1});
  EXPECT_NEAR(mean_red(image), kLitRadiance * kTransparentShare, 1e-6);
}

// BLEND, alpha 0.3: 70% of the light on average. 4096 pixels x 4 samples, each shadow ray passing
// with probability 0.7: the mean's standard deviation is sqrt(0.21 / 16384) of the lit radiance.
TEST(AlphaCutout, BlendedShadowLetsThroughOneMinusAlpha) {
  const Scene s = shadow_scene(AlphaMode::kBlend, false, 0.3f);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const Image image = render(s, *accel, PathIntegrator(s), {.spp = 4, .seed = 1});
  const double n = kSide * kSide * 4.0;
  EXPECT_NEAR(mean_red(image) / kLitRadiance, 0.7, 4.0 * std::sqrt(0.21 / n));
}

// Blended and masked surfaces seen, bounced off and shadowing (full paths), rendered with one
// thread in 8-pixel tiles and with all threads in 16-pixel tiles: the same image, bit for bit.
TEST(AlphaCutout, ImageIsTheSameForAnyThreadCountAndTileSize) {
  Scene s = shadow_scene(AlphaMode::kBlend, true, 0.6f);
  s.materials[1].albedo = glm::vec3(0.8f);
  s.camera = Camera::look_at(kSide, kSide, {0.5f, -1.0f, -1.5f}, {0.5f, 2.0f, 0.5f},
                             {0.0f, -1.0f, 0.0f}, kSide);
  const auto accel = make_accel(AccelKind::kBvh, s, kDefaultKernel);
  const PathIntegrator pt(s);
  const Image one = render(s, *accel, pt, {.threads = 1, .tile_size = 8, .spp = 4, .seed = 2});
  const Image all = render(s, *accel, pt, {.threads = 0, .tile_size = 16, .spp = 4, .seed = 2});
  EXPECT_TRUE(same_bits(one, all));
  // And the cut-out shows: the same scene with an opaque quad renders otherwise.
  Scene opaque = s;
  opaque.materials[1].alpha_mode = AlphaMode::kOpaque;
  const auto opaque_accel = make_accel(AccelKind::kBvh, opaque, kDefaultKernel);
  EXPECT_FALSE(same_bits(one, render(opaque, *opaque_accel, PathIntegrator(opaque),
                                     {.threads = 1, .tile_size = 8, .spp = 4, .seed = 2})));
}

}  // namespace
}  // namespace tritrace
