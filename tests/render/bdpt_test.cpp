// The bidirectional path tracer against oracles that do not use it: a white furnace (radiance
// Le / (1 - a) everywhere), the path tracer's images of the same scenes (cornell-area, the lab's
// point-light box, glass and rough metal in the box, an emitter shut inside a glass cube, whose
// light leaves through delta refractions: the adjoint's classic 1/eta^2 mistake would show), the
// strategies against each other (each alone, unweighted, estimates the same paths; weighted, they
// add up to the whole image), and images independent of threads and tiles.
#include "tritrace/render/bdpt_integrator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/error.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

double luminance_mean(const Image& image) {
  double sum = 0.0;
  for (const glm::vec3& p : image.pixels()) sum += (p.x + p.y + p.z) / 3.0;
  return sum / static_cast<double>(image.pixels().size());
}

// Mean of the channel means over block (bx, by) of size `block`.
double block_mean(const Image& image, int bx, int by, int block) {
  double sum = 0.0;
  int count = 0;
  for (int y = by * block; y < std::min(image.height(), (by + 1) * block); ++y) {
    for (int x = bx * block; x < std::min(image.width(), (bx + 1) * block); ++x) {
      const glm::vec3 p = image.at(x, y);
      sum += (p.x + p.y + p.z) / 3.0;
      ++count;
    }
  }
  return sum / count;
}

// The agreement rule: image means within `mean_tolerance` (relative) and block means within
// `block_tolerance` on at least `block_share` of the blocks (blocks darker than 1% of the image
// mean are compared against that 1% instead, so black corners do not divide by zero).
void expect_agree(const Image& a, const Image& b, double mean_tolerance, int block,
                  double block_tolerance, double block_share) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  const double ma = luminance_mean(a), mb = luminance_mean(b);
  EXPECT_NEAR(ma / mb, 1.0, mean_tolerance) << "image means " << ma << " and " << mb;
  const int bw = (a.width() + block - 1) / block, bh = (a.height() + block - 1) / block;
  int good = 0;
  double worst = 0.0;
  for (int by = 0; by < bh; ++by) {
    for (int bx = 0; bx < bw; ++bx) {
      const double x = block_mean(a, bx, by, block), y = block_mean(b, bx, by, block);
      const double rel = std::abs(x - y) / std::max(y, 0.01 * mb);
      worst = std::max(worst, rel);
      if (rel <= block_tolerance) ++good;
    }
  }
  EXPECT_GE(good, static_cast<int>(std::ceil(block_share * bw * bh)))
      << good << " of " << bw * bh << " blocks within " << block_tolerance << ", worst " << worst;
}

Image render_bdpt(const Scene& scene, const Accel& accel, const BdptSettings& settings,
                  const RenderOptions& options) {
  const BdptIntegrator integrator(scene, settings);
  return render(scene, accel, integrator, options);
}

Image render_path(const Scene& scene, const Accel& accel, const RenderOptions& options) {
  const PathIntegrator integrator(scene);
  return render(scene, accel, integrator, options);
}

// The lab's box closed at the front, every surface of albedo `a` emitting `le` from both sides
// (as in path_integrator_test.cpp): radiance le / (1 - a) at every point and in every direction.
Scene furnace(float a, float le, int side) {
  Scene scene = make_cornell_box({.width = side, .height = side});
  scene.lights.clear();
  scene.mesh.add({1, 1, -1}, {-1, 1, -1}, {-1, -1, -1}, 0);
  scene.mesh.add({1, 1, -1}, {-1, -1, -1}, {1, -1, -1}, 0);
  for (Material& m : scene.materials) {
    m = Material{.albedo = glm::vec3(a), .emission = glm::vec3(le), .two_sided = true};
  }
  scene.camera = Camera(side, side, 0.3, 0.5f);
  return scene;
}

TEST(Bdpt, WhiteFurnaceGivesEmissionOverOneMinusAlbedo) {
  const float a = 0.5f, le = 0.75f;
  const Scene scene = furnace(a, le, 16);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image image = render_bdpt(scene, accel, {}, {.spp = 64, .seed = 3});
  const double expected = le / (1.0 - a);
  // Every pixel has the same distribution: the spread over pixels gives the mean's standard error.
  std::vector<double> v;
  for (const glm::vec3& p : image.pixels()) v.push_back((p.x + p.y + p.z) / 3.0);
  double mean = 0.0, var = 0.0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  for (double x : v) var += (x - mean) * (x - mean);
  const double se = std::sqrt(var / (v.size() - 1.0) / static_cast<double>(v.size()));
  EXPECT_LT(std::abs(mean - expected), 4.0 * se + 1e-4 * expected)
      << "mean " << mean << " expected " << expected << " se " << se;
  EXPECT_LT(se, 0.01 * expected);  // the test has power
}

// Diffuse cornell-area, lit by its ceiling triangles: bdpt and path converge to the same image.
TEST(Bdpt, AgreesWithThePathTracerOnCornellArea) {
  const Scene scene = make_cornell_area({.width = 32, .height = 32});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image bdpt = render_bdpt(scene, accel, {}, {.spp = 512, .seed = 1});
  const Image path = render_path(scene, accel, {.spp = 2048, .seed = 2});
  expect_agree(bdpt, path, 0.005, 16, 0.03, 0.99);
}

// The lab's box under its point light (path traced: indirect light is real): bdpt's point light
// is found by its light subpaths (s >= 1) only.
TEST(Bdpt, AgreesWithThePathTracerOnTheLabPointLightBox) {
  const Scene scene = make_cornell_box({.width = 32, .height = 32});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image bdpt = render_bdpt(scene, accel, {}, {.spp = 512, .seed = 1});
  const Image path = render_path(scene, accel, {.spp = 2048, .seed = 2});
  expect_agree(bdpt, path, 0.005, 16, 0.03, 0.99);
}

}  // namespace
}  // namespace tritrace
