// bdpt's view rays (BdptSettings::specular_view_rays, docs/BDPT.md): extra camera rays for the
// light seen through specular surfaces only (E S+ L), averaged with the sample's own estimate of
// those paths. Checked against closed forms that do not use the renderer (light through a glass
// slab, whose transmittance with every internal reflection is (1 - F) / (1 + F), and a glass
// slab in a uniform environment, a furnace), with and without the rays, against the path tracer
// on scenes/caustics.json, and for the variance they are there to remove.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "example_scene.h"
#include "mean_and_error.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"

namespace tritrace {
namespace {

using testing_mc::expect_same_mean;
using testing_mc::luminance_mean;
using testing_mc::mean_of_renders;
using testing_mc::same_bits;

constexpr int kSide = 32;
constexpr float kIor = 1.5f;

// A quad [-10, x1] x [-10, 10] at z whose lab normal cross(e2, e1) points to -z (towards the
// camera at the origin), or to +z where `back` (a dielectric's inside is opposite its lab normal).
void add_quad_at_z(TriangleMesh& mesh, float z, uint32_t m, bool back = false, float x1 = 10.0f) {
  const glm::vec3 a(-10.0f, -10.0f, z), b(x1, -10.0f, z), c(x1, 10.0f, z), d(-10.0f, 10.0f, z);
  if (back) {
    mesh.add(a, c, b, m);
    mesh.add(a, d, c, m);
  } else {
    mesh.add(a, b, c, m);
    mesh.add(a, c, d, m);
  }
}

// Unpolarised Fresnel reflectance of a smooth interface from air into index n at incidence cos_i
// (Hecht, "Optics", sec. 4.6), written here from the textbook formula.
double fresnel(double cos_i, double n) {
  const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_i * cos_i)) / n;
  const double cos_t = std::sqrt(std::max(0.0, 1.0 - sin_t * sin_t));
  const double rs = (cos_i - n * cos_t) / (cos_i + n * cos_t);
  const double rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

// The camera at the origin looking along +z through a smooth glass slab (index 1.5, faces at
// z = 2 and 2.5) at a two-sided emitter of radiance le at z = 5 that fills the view (or, without
// it, a uniform environment of radiance le). Nothing else: every path that carries light is E S+ L
// (no connection reaches it: the slab is specular and the camera a pinhole, or a thin lens).
// `half`: the slab covers x < 0 only, and the camera sees the emitter beside it directly.
Scene slab_scene(bool emitter, float le, float lens_radius = 0.0f, bool half = false) {
  Scene scene;
  scene.materials = {
      Material{.albedo = glm::vec3(1.0f),
               .type = MaterialType::kDielectric,
               .roughness = 0.0f,
               .ior = kIor},
      Material{.albedo = glm::vec3(0.0f), .emission = glm::vec3(le), .two_sided = true}};
  add_quad_at_z(scene.mesh, 2.0f, 0, false, half ? 0.0f : 10.0f);
  add_quad_at_z(scene.mesh, 2.5f, 0, true, half ? 0.0f : 10.0f);
  if (emitter) {
    add_quad_at_z(scene.mesh, 5.0f, 1);
  } else {
    scene.environment = glm::vec3(le);
  }
  scene.camera = Camera::look_at(kSide, kSide, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f},
                                 {0.0f, 1.0f, 0.0f}, Camera::focal_for_vertical_fov(kSide, 30.0));
  if (lens_radius > 0.0f) scene.camera = scene.camera.with_lens(lens_radius, 5.0f);
  return scene;
}

// The slab's transmittance at each pixel centre's incidence, with every even number of reflections
// inside (the inside's reflectance at the refracted angle equals the outside's):
// (1 - F)^2 (1 + F^2 + F^4 + ...) = (1 - F) / (1 + F).
Image slab_transmittance(const Scene& scene, float le) {
  Image expected(kSide, kSide);
  for (int y = 0; y < kSide; ++y) {
    for (int x = 0; x < kSide; ++x) {
      const Ray ray =
          scene.camera.ray_through(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
      const double f = fresnel(std::abs(glm::normalize(ray.dir).z), kIor);
      expected.at(x, y) = glm::vec3(static_cast<float>(le * (1.0 - f) / (1.0 + f)));
    }
  }
  return expected;
}

double mean_squared_difference(const Image& a, const Image& b) {
  double sum = 0.0;
  for (size_t i = 0; i < a.pixels().size(); ++i) {
    const glm::vec3 d = a.pixels()[i] - b.pixels()[i];
    sum += glm::dot(d, d) / 3.0;
  }
  return sum / static_cast<double>(a.pixels().size());
}

Image render_with(const Scene& scene, const Accel& accel, int view_rays, RenderOptions options) {
  const BdptIntegrator bdpt(scene, BdptSettings{.specular_view_rays = view_rays});
  return render(scene, accel, bdpt, options);
}

// The light through the slab: with and without view rays (and with a thin lens, whose rays draw
// lens points too) the image is the closed form's, to 0.4% over the image. Counting the sample's
// own estimate of these paths whole, or the view rays' whole, would make it 1.75 or 3.25 times
// the closed form with n = 3.
TEST(BdptViews, LightThroughAGlassSlabIsItsTransmittance) {
  constexpr float kLe = 2.0f;
  for (const float lens : {0.0f, 0.05f}) {
    const Scene scene = slab_scene(true, kLe, lens);
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    const double expected = luminance_mean(slab_transmittance(scene, kLe));
    for (const int n : {0, 3}) {
      const double mean = luminance_mean(render_with(scene, accel, n, {.spp = 64, .seed = 5}));
      std::printf("  lens %.2f, %d view rays: %.6f, closed form %.6f\n", lens, n, mean, expected);
      EXPECT_NEAR(mean, expected, 0.004 * expected) << "lens " << lens << ", view rays " << n;
    }
  }
}

// A furnace: the slab in a uniform environment of radiance le reflects or transmits every path to
// the environment with weight 1 (its glass is clear), so every pixel is le. Both the transmitted
// paths (E S S L) and the reflected ones (E S L, towards the environment behind the camera) are
// view rays' paths.
TEST(BdptViews, GlassSlabInAUniformEnvironmentIsAFurnace) {
  constexpr float kLe = 0.7f;
  const Scene scene = slab_scene(false, kLe);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  for (const int n : {0, 3}) {
    const double mean = luminance_mean(render_with(scene, accel, n, {.spp = 32, .seed = 8}));
    std::printf("  %d view rays: %.6f (furnace %.6f)\n", n, mean, kLe);
    EXPECT_NEAR(mean, kLe, 0.003 * kLe) << "view rays " << n;
  }
}

// What the rays are for: with independent numbers each of the n + 1 estimates of an E S+ L path
// is independent, so the pixels' squared error against the closed form falls about n + 1 = 4
// times at the same spp (asked: at least 2.5 times).
TEST(BdptViews, ViewRaysCutTheVarianceOfLightSeenThroughGlass) {
  constexpr float kLe = 2.0f;
  const Scene scene = slab_scene(true, kLe);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image expected = slab_transmittance(scene, kLe);
  const RenderOptions options{.spp = 16, .seed = 11, .sampler = SamplerKind::kIndependent};
  const double without = mean_squared_difference(render_with(scene, accel, 0, options), expected);
  const double with = mean_squared_difference(render_with(scene, accel, 3, options), expected);
  std::printf("  squared error: %.3g without view rays, %.3g with 3 (%.2fx)\n", without, with,
              without / with);
  EXPECT_GT(without, 2.5 * with);
}

// scenes/caustics.json, where the light is seen through the faceted sphere: bdpt with view rays
// (the default) agrees with the path tracer and with bdpt without them.
TEST(BdptViews, CausticsSceneAgreesWithThePathTracerAndWithoutViewRays) {
  const Scene scene = testing_scenes::example_scene("caustics.json", 24);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator with(scene), without(scene, BdptSettings{.specular_view_rays = 0});
  const testing_mc::MeanAndError a = mean_of_renders(scene, accel, with, 64, 10, 6);
  expect_same_mean(a, mean_of_renders(scene, accel, PathIntegrator(scene), 256, 20, 6), 0.02);
  expect_same_mean(a, mean_of_renders(scene, accel, without, 64, 30, 6), 0.02);
}

// The pixels that take view rays follow the camera: an integrator kept across a camera move (as the
// viewer keeps it) renders the new view as one made for it does, bit for bit, and the rays change
// only pixels that see the glass.
// The pixels that take view rays follow the camera: an integrator kept across a camera move (as the
// viewer keeps it) renders the new view as one made for it does, bit for bit. The slab covers half
// the view, and the rays change only the pixels that see it.
TEST(BdptViews, PixelsFollowTheCamera) {
  Scene scene = slab_scene(true, 2.0f, 0.0f, true);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator kept(scene);
  const RenderOptions options{.threads = 1, .spp = 4, .seed = 3};
  (void)render(scene, accel, kept, options);
  // The slab's edge moves from the middle of the view to 78% of its width from the left: the
  // pixels between take view rays after the move only.
  scene.camera = scene.camera.with_position(glm::vec3(-0.3f, 0.0f, 0.0f));
  const Image moved = render(scene, accel, kept, options);
  EXPECT_TRUE(same_bits(moved, render(scene, accel, BdptIntegrator(scene), options)));
  const Image bare = render_with(scene, accel, 0, options);
  int changed = 0, changed_without_glass = 0;
  for (int y = 0; y < kSide; ++y) {
    for (int x = 0; x < kSide; ++x) {
      if (moved.at(x, y) == bare.at(x, y)) continue;
      ++changed;
      // A pixel sees the glass if any of a 16 x 16 grid of rays through it meets it first.
      bool glass = false;
      for (int j = 0; j < 256 && !glass; ++j) {
        const Ray ray = scene.camera.ray_through(
            static_cast<float>(x) + (0.5f + static_cast<float>(j % 16)) / 16,
            static_cast<float>(y) + (0.5f + static_cast<float>(j / 16)) / 16);
        const Hit hit = accel.intersect(ray);
        glass = hit.found() && scene.material_of(hit.prim) == 0;
      }
      changed_without_glass += glass ? 0 : 1;
    }
  }
  std::printf("  %d of %d pixels changed by view rays, %d of them not seeing the glass\n", changed,
              kSide * kSide, changed_without_glass);
  EXPECT_GT(changed, kSide * kSide * 6 / 10);
  EXPECT_EQ(changed_without_glass, 0);
}

}  // namespace
}  // namespace tritrace
