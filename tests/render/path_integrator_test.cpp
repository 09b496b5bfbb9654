// The path tracer against exact answers: a white furnace (a closed room of albedo a emitting Le
// everywhere has radiance Le / (1 - a) at every point), direct light from the lab's point light at
// hand-computed pixels, agreement of its three ways of finding emitters (MIS, light sampling only,
// BSDF sampling only), the solid angle density of light sampling against the analytic solid angle
// of a triangle, and images independent of threads, tiles and how samples are split into calls;
// the same for environment maps (a furnace from a map file, strategies, rotate and scale).
#include "tritrace/render/path_integrator.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <numbers>
#include <vector>

#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/math/sampling.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/scene_loader.h"
#include "tritrace/scene/transform.h"

namespace tritrace {
namespace {

// The lab's box, its front (z = -1) closed by two more triangles, every surface of albedo `a`
// emitting `le` from both sides; the camera inside, half way to the back wall.
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

struct PixelStats {
  double mean = 0.0;  // over the pixels and channels
  double pixel_sd = 0.0;
  double max_abs_z = 0.0;  // of single pixels, against `expected`, in units of pixel_sd
};

PixelStats stats_against(const Image& image, double expected) {
  std::vector<double> v;
  for (const glm::vec3& p : image.pixels()) v.push_back((p.x + p.y + p.z) / 3.0);
  PixelStats s;
  for (double x : v) s.mean += x;
  s.mean /= static_cast<double>(v.size());
  double var = 0.0;
  for (double x : v) var += (x - s.mean) * (x - s.mean);
  s.pixel_sd = std::sqrt(var / static_cast<double>(v.size() - 1));
  for (double x : v) s.max_abs_z = std::max(s.max_abs_z, std::abs(x - expected) / s.pixel_sd);
  return s;
}

class WhiteFurnace : public ::testing::TestWithParam<float> {};

// In a furnace every pixel has the same distribution, so the spread over the pixels measures each
// pixel's noise; the image mean is a z-test with that standard error.
TEST_P(WhiteFurnace, EveryPixelIsEmissionOverOneMinusAlbedo) {
  const float a = GetParam();
  const float le = 0.75f;
  const Scene scene = furnace(a, le, 32);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const Image image = render(scene, accel, integrator, {.spp = 256, .seed = 7});
  const double expected = le / (1.0 - a);
  const PixelStats s = stats_against(image, expected);
  const double standard_error = s.pixel_sd / std::sqrt(static_cast<double>(image.pixels().size()));
  EXPECT_LT(std::abs(s.mean - expected), 4.0 * standard_error)
      << "mean " << s.mean << " expected " << expected << " se " << standard_error;
  // No pixel strays: 5 standard deviations over 1024 pixels.
  EXPECT_LT(s.max_abs_z, 5.0);
  // The test has the power to tell an albedo 1% off (a transport that loses or gains 1% per
  // bounce): its answer is more than 4 standard errors away.
  const double off = le / (1.0 - 1.01 * a);
  EXPECT_GT(off - expected, 4.0 * standard_error);
}

INSTANTIATE_TEST_SUITE_P(Albedos, WhiteFurnace, ::testing::Values(0.5f, 0.8f, 0.95f),
                         [](const auto& info) {
                           // Appended rather than "a" + ..., which trips GCC 12's -Wrestrict.
                           std::string name = "a";
                           name += std::to_string(static_cast<int>(info.param * 100));
                           return name;
                         });

// Direct light only (max depth 1) from the lab's point light, through pixel centres: radiance
// rho / pi * 14 max(n.l, 0) / (4 pi r^2), worked out in double from where the camera ray meets
// the wall (not by tracing).
struct D3 {
  double x, y, z;
};

D3 centre_ray_meets_plane(int px, int py, int axis, double value) {
  const D3 o{0.0, 0.0, -3.0};
  const D3 d{px + 0.5 - 250.0, py + 0.5 - 250.0, 500.0};
  const double oc[3] = {o.x, o.y, o.z}, dc[3] = {d.x, d.y, d.z};
  const double s = (value - oc[axis]) / dc[axis];
  return {o.x + s * d.x, o.y + s * d.y, o.z + s * d.z};
}

double direct_radiance(D3 x, D3 n, double rho) {
  const D3 light{0.0, -0.5, -0.7};
  const D3 r{light.x - x.x, light.y - x.y, light.z - x.z};
  const double r2 = r.x * r.x + r.y * r.y + r.z * r.z;
  const double cos = std::max(0.0, (r.x * n.x + r.y * n.y + r.z * n.z) / std::sqrt(r2));
  return rho / std::numbers::pi * 14.0 * cos / (4.0 * std::numbers::pi * r2);
}

glm::vec3 trace_pixel_centre(const Scene& scene, const Accel& accel, const PathIntegrator& pt,
                             int x, int y) {
  const Ray ray =
      scene.camera.ray_through(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
  Sampler sampler(3);
  sampler.start_pixel_sample(x, y, 0);
  glm::vec3 radiance;
  pt.radiance(SampleBatch{std::span<const Ray>(&ray, 1), std::span<Sampler>(&sampler, 1)},
              SampleOutput{std::span<glm::vec3>(&radiance, 1)}, scene, accel);
  return radiance;
}

TEST(PathDirectLight, MatchesTheLabFormulaAtPixelCentres) {
  const Scene scene = make_cornell_box();
  const BruteForceAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene, PathSettings{.max_depth = 1});
  struct Case {
    int x, y, axis;
    double plane;
    D3 normal;
    glm::vec3 rho;
  };
  const Case cases[] = {
      {250, 150, 2, 1.0, {0, 0, -1}, {0.75f, 0.75f, 0.75f}},  // back wall above the tall block
      {100, 250, 0, -1.0, {1, 0, 0}, {0.75f, 0.15f, 0.75f}},  // purple wall
      {400, 200, 0, 1.0, {-1, 0, 0}, {0.75f, 0.75f, 0.15f}},  // yellow wall
      {96, 474, 1, 1.0, {0, -1, 0}, {0.15f, 0.75f, 0.15f}},   // floor in front of the blocks
  };
  for (const Case& c : cases) {
    const D3 x = centre_ray_meets_plane(c.x, c.y, c.axis, c.plane);
    const glm::vec3 got = trace_pixel_centre(scene, accel, pt, c.x, c.y);
    for (int k = 0; k < 3; ++k) {
      const double want = direct_radiance(x, c.normal, c.rho[k]);
      EXPECT_NEAR(got[k], want, 1e-5 * want + 1e-7) << "pixel " << c.x << "," << c.y;
    }
  }
  // In the tall block's shadow (the lab test's pixel, a separate tracer's choice): no direct light.
  EXPECT_EQ(trace_pixel_centre(scene, accel, pt, 138, 402), glm::vec3(0.0f));
}

TEST(PathDirectLight, MaxDepthZeroSeesOnlyEmitters) {
  const Scene scene = make_cornell_area({.width = 64, .height = 64});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene, PathSettings{.max_depth = 0});
  const Image image = render(scene, accel, pt, {.spp = 1});
  int lit = 0;
  for (const glm::vec3& p : image.pixels()) {
    EXPECT_TRUE(p == glm::vec3(0.0f) || p == kAreaLightRadiance);
    lit += p == kAreaLightRadiance;
  }
  EXPECT_GT(lit, 0) << "the camera sees the ceiling light";
}

// Mean radiance over blocks of the image and over the whole image, from independent renders
// (different seeds): the batch-to-batch spread gives each mean's standard error without assuming
// anything about the estimator.
struct BlockMeans {
  std::vector<double> mean, standard_error;  // per 8 x 8 block, then the whole image last
};

BlockMeans block_means(const Scene& scene, const Accel& accel, const PathSettings& settings,
                       uint64_t seed0, uint32_t spp) {
  constexpr int kBatches = 16, kBlock = 8;
  const PathIntegrator pt(scene, settings);
  const int w = scene.camera.width(), h = scene.camera.height();
  const int blocks = (w / kBlock) * (h / kBlock);
  std::vector<std::vector<double>> per_batch(kBatches, std::vector<double>(blocks + 1, 0.0));
  for (int b = 0; b < kBatches; ++b) {
    const Image image = render(scene, accel, pt, {.spp = spp, .seed = seed0 + b});
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const glm::vec3 p = image.at(x, y);
        const double v = (p.x + p.y + p.z) / 3.0;
        per_batch[b][(y / kBlock) * (w / kBlock) + x / kBlock] += v / (kBlock * kBlock);
        per_batch[b][blocks] += v / (w * h);
      }
    }
  }
  BlockMeans out;
  for (int k = 0; k <= blocks; ++k) {
    double m = 0.0, v = 0.0;
    for (int b = 0; b < kBatches; ++b) m += per_batch[b][k] / kBatches;
    for (int b = 0; b < kBatches; ++b) v += (per_batch[b][k] - m) * (per_batch[b][k] - m);
    out.mean.push_back(m);
    out.standard_error.push_back(std::sqrt(v / (kBatches - 1) / kBatches));
  }
  return out;
}

// Each strategy alone is unbiased, and so is their MIS combination: they must agree. MIS and light
// sampling are precise enough that the image means resolve a fraction of a percent (a strategy
// counted twice, or a wrong density, shows); BSDF sampling alone is far noisier with this small
// light and is compared with what its noise allows.
// k-th block (the last entry: the whole image) of a and b differ by less than 4.5 standard errors.
int expect_agree(const BlockMeans& a, const BlockMeans& b, const char* what) {
  int checked = 0;
  for (size_t k = 0; k < a.mean.size(); ++k) {
    const double se = std::hypot(a.standard_error[k], b.standard_error[k]);
    if (se == 0.0 && a.mean[k] == b.mean[k]) continue;
    ++checked;
    EXPECT_LT(std::abs(a.mean[k] - b.mean[k]), 4.5 * se)
        << what << (k + 1 == a.mean.size() ? " image" : " block ") << k << ": " << a.mean[k]
        << " vs " << b.mean[k] << " (se " << se << ")";
  }
  return checked;
}

using Strategy = PathSettings::Strategy;

// cornell-area seen from the lab camera's position looking down at the blocks and floor: the light
// itself is out of view, so that pixels straddling its edge (10 against about 0.1 around them) do
// not dominate the noise of the image means.
Scene cornell_area_below_the_light() {
  Scene scene = make_cornell_area({.width = 32, .height = 32});
  scene.camera =
      Camera::look_at(32, 32, {0.0f, 0.0f, -3.0f}, {0.0f, 0.6f, 0.2f}, {0.0f, -1.0f, 0.0f}, 40.0f);
  return scene;
}

TEST(PathStrategies, MisLightOnlyAndBsdfOnlyAgreeOnCornellArea) {
  const Scene scene = cornell_area_below_the_light();
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BlockMeans mis = block_means(scene, accel, {.strategy = Strategy::kMis}, 100, 16);
  const BlockMeans light = block_means(scene, accel, {.strategy = Strategy::kLightOnly}, 200, 16);
  const BlockMeans bsdf = block_means(scene, accel, {.strategy = Strategy::kBsdfOnly}, 300, 16);
  EXPECT_GT(expect_agree(mis, light, "mis vs light only"), 16);
  EXPECT_GT(expect_agree(mis, bsdf, "mis vs bsdf only"), 16);
  // MIS is the least noisy of the three over the image (the point of combining them).
  double se_mis = 0.0, se_bsdf = 0.0;
  for (size_t k = 0; k < mis.mean.size(); ++k) {
    se_mis += mis.standard_error[k];
    se_bsdf += bsdf.standard_error[k];
  }
  EXPECT_LT(se_mis, se_bsdf);
}

// Light found directly and after one bounce (max depth 2), where MIS and light sampling are precise
// enough for the image means to resolve half a percent: a strategy counted twice, or a density
// off by a factor, shows here.
TEST(PathStrategies, MisAndLightSamplingAgreeToHalfAPercent) {
  const Scene scene = cornell_area_below_the_light();
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BlockMeans mis =
      block_means(scene, accel, {.max_depth = 2, .strategy = Strategy::kMis}, 400, 48);
  const BlockMeans light =
      block_means(scene, accel, {.max_depth = 2, .strategy = Strategy::kLightOnly}, 500, 48);
  expect_agree(mis, light, "mis vs light only, depth 2");
  const double image_se = std::hypot(mis.standard_error.back(), light.standard_error.back());
  ::testing::Test::RecordProperty("image_mean", std::to_string(mis.mean.back()));
  ::testing::Test::RecordProperty("image_standard_error", std::to_string(image_se));
  EXPECT_LT(4.5 * image_se, 0.005 * mis.mean.back()) << "the test resolves half a percent";
}

// The same agreement with glossy surfaces, where the strategies' weights come from the Bsdf's eval
// and pdf: a wrong density or a lobe counted twice shows as a disagreement. Walls principled
// (varnished diffuse), blocks a rough metal; the light stays diffuse and emissive.
TEST(PathStrategies, AgreeWithGlossyMaterials) {
  Scene scene = cornell_area_below_the_light();
  for (Material& m : scene.materials) {
    if (m.emits()) continue;
    const glm::vec3 albedo = m.albedo;
    m = Material{.albedo = albedo, .type = MaterialType::kPrincipled, .roughness = 0.5f};
  }
  // The blocks are the last triangles of the box: give them their own rough gold material.
  scene.materials.push_back(Material{
      .albedo = glm::vec3(1.0f, 0.8f, 0.35f), .type = MaterialType::kConductor, .roughness = 0.4f});
  TriangleMesh mesh;
  const uint32_t gold = static_cast<uint32_t>(scene.materials.size() - 1);
  for (size_t k = 0; k < scene.mesh.size(); ++k) {
    const uint32_t m = scene.mesh.material()[k];
    const bool block = k >= 10 && !scene.materials[m].emits();
    mesh.add(scene.mesh.vertex(k, 0), scene.mesh.vertex(k, 1), scene.mesh.vertex(k, 2),
             block ? gold : m);
  }
  scene.mesh = std::move(mesh);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BlockMeans mis =
      block_means(scene, accel, {.max_depth = 3, .strategy = Strategy::kMis}, 600, 16);
  const BlockMeans light =
      block_means(scene, accel, {.max_depth = 3, .strategy = Strategy::kLightOnly}, 700, 16);
  const BlockMeans bsdf =
      block_means(scene, accel, {.max_depth = 3, .strategy = Strategy::kBsdfOnly}, 800, 16);
  EXPECT_GT(expect_agree(mis, light, "glossy: mis vs light only"), 16);
  EXPECT_GT(expect_agree(mis, bsdf, "glossy: mis vs bsdf only"), 16);
}

// Mirrors and smooth glass: light that reaches an emitter through a delta lobe can be found by no
// light sample (a shadow ray cannot follow a mirror or a refraction), so every strategy, light
// sampling alone included, must count it when the path hits the emitter. The tall block is a
// perfect mirror, the short one smooth glass; the camera sees the ceiling light in the mirror and
// the floor lit through the glass.
TEST(PathStrategies, AgreeWithMirrorsAndSmoothGlass) {
  Scene scene = cornell_area_below_the_light();
  scene.materials.push_back(
      Material{.albedo = glm::vec3(0.9f), .type = MaterialType::kConductor, .roughness = 0.0f});
  const uint32_t mirror = static_cast<uint32_t>(scene.materials.size() - 1);
  scene.materials.push_back(
      Material{.albedo = glm::vec3(1.0f), .type = MaterialType::kDielectric, .ior = 1.5f});
  const uint32_t glass = static_cast<uint32_t>(scene.materials.size() - 1);
  // Triangles 10-19 are the short block, 20-29 the tall one (cornell_box.cpp's order).
  TriangleMesh mesh;
  for (size_t k = 0; k < scene.mesh.size(); ++k) {
    uint32_t m = scene.mesh.material()[k];
    if (k >= 10 && k < 20) m = glass;
    if (k >= 20 && k < 30) m = mirror;
    mesh.add(scene.mesh.vertex(k, 0), scene.mesh.vertex(k, 1), scene.mesh.vertex(k, 2), m);
  }
  scene.mesh = std::move(mesh);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BlockMeans mis =
      block_means(scene, accel, {.max_depth = 4, .strategy = Strategy::kMis}, 1200, 16);
  const BlockMeans light =
      block_means(scene, accel, {.max_depth = 4, .strategy = Strategy::kLightOnly}, 1300, 16);
  const BlockMeans bsdf =
      block_means(scene, accel, {.max_depth = 4, .strategy = Strategy::kBsdfOnly}, 1400, 16);
  EXPECT_GT(expect_agree(mis, light, "delta lobes: mis vs light only"), 16);
  EXPECT_GT(expect_agree(mis, bsdf, "delta lobes: mis vs bsdf only"), 16);
}

// A pane of "glass" with index 1 and a clear tint changes nothing: light passes straight through
// (F = 0, no bending, no 1/eta^2). Its image must agree with the scene without it.
TEST(PathDielectric, IndexOneIsInvisible) {
  Scene plain = cornell_area_below_the_light();
  Scene with_pane = plain;
  with_pane.materials.push_back(
      Material{.albedo = glm::vec3(1.0f), .type = MaterialType::kDielectric, .ior = 1.0f});
  const uint32_t pane = static_cast<uint32_t>(with_pane.materials.size() - 1);
  // Across the room between the camera and the blocks.
  with_pane.mesh.add({-0.9f, -0.9f, -0.5f}, {0.9f, -0.9f, -0.5f}, {0.9f, 0.9f, -0.5f}, pane);
  with_pane.mesh.add({-0.9f, -0.9f, -0.5f}, {0.9f, 0.9f, -0.5f}, {-0.9f, 0.9f, -0.5f}, pane);
  const BvhAccel a(plain.mesh, kDefaultKernel), b(with_pane.mesh, kDefaultKernel);
  // Default depth: Russian roulette, not a vertex count, ends paths, so crossing the pane (a
  // vertex) does not change what is estimated.
  const BlockMeans without = block_means(plain, a, {}, 900, 16);
  const BlockMeans through = block_means(with_pane, b, {}, 901, 16);
  EXPECT_GT(expect_agree(without, through, "pane of index 1"), 8);
}

// Scale and translation invariance: cornell-area (lit by emissive triangles, whose radiance does
// not change with the scene's size, so nothing else needs rescaling) moved as a whole, camera
// included, renders the same picture. With the same seed the paths take the same random numbers
// and differ only by rounding (a path may part from its twin where a roulette coin or a shadow ray
// lands on a threshold), so the images agree far more closely than their noise: the image means
// to a part in 1000 and most pixels to 1% (measured: all 1024 scaled by 1e-3, 1e4 and 37 with a
// translation of 5e3; 800 translated by 1e4, where positions are known only to float's 2^-10, a
// 2000th of the box, and mean ratio 0.9995; the bound is 90% and 70%). Ray offsets that did not
// follow the scene's scale or position would show as acne (darker) or leaks (brighter) everywhere.
// Independent seeds also agree block by block within their noise.
struct PathPlacement {
  const char* name;
  Similarity xf;
  double close_fraction;  // of pixels within 1% of the unmoved scene's
};

class MovedPathScene : public ::testing::TestWithParam<PathPlacement> {};

TEST_P(MovedPathScene, RendersTheSameImageWithinNoise) {
  const Scene base = cornell_area_below_the_light();
  const Scene moved = transformed(base, GetParam().xf);
  const BvhAccel base_accel(base.mesh, kDefaultKernel), moved_accel(moved.mesh, kDefaultKernel);
  const PathIntegrator base_pt(base), moved_pt(moved);
  const Image want = render(base, base_accel, base_pt, {.spp = 64, .seed = 21});
  const Image got = render(moved, moved_accel, moved_pt, {.spp = 64, .seed = 21});
  double want_sum = 0.0, got_sum = 0.0;
  int close = 0;
  for (size_t i = 0; i < want.pixels().size(); ++i) {
    const glm::vec3 a = want.pixels()[i], b = got.pixels()[i];
    const double va = (a.x + a.y + a.z) / 3.0, vb = (b.x + b.y + b.z) / 3.0;
    want_sum += va;
    got_sum += vb;
    close += std::abs(va - vb) <= 0.01 * va;
  }
  const double n = static_cast<double>(want.pixels().size());
  ::testing::Test::RecordProperty("close_pixels", std::to_string(close));
  ::testing::Test::RecordProperty("mean_ratio", std::to_string(got_sum / want_sum));
  EXPECT_NEAR(got_sum / want_sum, 1.0, 1e-3) << GetParam().name;
  EXPECT_GE(close, GetParam().close_fraction * n) << GetParam().name;
  const BlockMeans a = block_means(base, base_accel, {}, 1500, 8);
  const BlockMeans b = block_means(moved, moved_accel, {}, 1600, 8);
  EXPECT_GT(expect_agree(a, b, GetParam().name), 16);
}

INSTANTIATE_TEST_SUITE_P(
    Placements, MovedPathScene,
    ::testing::Values(PathPlacement{"ScaledDownBy1000", {1e-3f, glm::vec3(0.0f)}, 0.9},
                      PathPlacement{"ScaledUpBy10000", {1e4f, glm::vec3(0.0f)}, 0.9},
                      PathPlacement{"TranslatedBy10000", {1.0f, glm::vec3(1e4f)}, 0.7},
                      PathPlacement{
                          "ScaledAndTranslated", {37.0f, glm::vec3(-250.0f, 80.0f, 5e3f)}, 0.9}),
    [](const auto& info) { return std::string(info.param.name); });

// The solid angle a triangle subtends from x: Van Oosterom and Strackee, "The Solid Angle of a
// Plane Triangle", IEEE Trans. Biomed. Eng. 30(2), 1983, in double.
double solid_angle(glm::dvec3 x, glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) {
  const glm::dvec3 r1 = a - x, r2 = b - x, r3 = c - x;
  const double l1 = glm::length(r1), l2 = glm::length(r2), l3 = glm::length(r3);
  const double num = glm::dot(r1, glm::cross(r2, r3));
  const double den =
      l1 * l2 * l3 + glm::dot(r1, r2) * l3 + glm::dot(r1, r3) * l2 + glm::dot(r2, r3) * l1;
  return std::abs(2.0 * std::atan2(num, den));
}

// E[1 / pdf] over light samples is the solid angle of what the sampler covers: the check that
// the density pdf_triangle and sample() report is the density of the points sample() draws.
TEST(LightSampling, SolidAngleDensityMatchesTheAnalyticSolidAngle) {
  Scene scene;
  scene.materials.push_back({.albedo = glm::vec3(0.0f), .emission = glm::vec3(1.0f)});
  const glm::vec3 a(-0.3f, 1.0f, 0.2f), b(0.9f, 1.1f, -0.4f), c(0.1f, 0.8f, 0.9f);
  scene.mesh.add(a, b, c, 0);
  scene.materials[0].two_sided = true;
  const LightSampler lights(scene);
  for (const glm::vec3 x :
       {glm::vec3(0.0f), glm::vec3(0.5f, -1.0f, 2.0f), glm::vec3(0.2f, 0.9f, 0.3f)}) {
    // Independent numbers: the test's 1% tolerance was chosen for plain Monte Carlo's error.
    Sampler sampler(11, SamplerKind::kIndependent);
    double sum = 0.0;
    constexpr int kN = 200000;
    for (int i = 0; i < kN; ++i) {
      sampler.start_pixel_sample(i, 0, 0);
      const LightSample s = lights.sample(scene, x, sampler.get_1d(), sampler.get_2d());
      ASSERT_GT(s.pdf, 0.0f);
      EXPECT_NEAR(lights.pdf_triangle(scene, 0, x, s.point), s.pdf, 1e-4f * s.pdf);
      sum += 1.0 / s.pdf;
    }
    const double want = solid_angle(x, a, b, c);
    EXPECT_NEAR(sum / kN, want, 0.01 * want) << "from " << x.x << "," << x.y << "," << x.z;
  }
}

// Lights are chosen in proportion to their power: a point light of power 14 (mean over channels)
// against a triangle of area 0.5 emitting 2 on one side (power 2 * 0.5 * pi).
TEST(LightSampling, ChoosesLightsInProportionToPower) {
  Scene scene;
  scene.lights.push_back({glm::vec3(0.0f, -1.0f, 0.0f), glm::vec3(10.0f, 14.0f, 18.0f)});
  scene.materials.push_back({.albedo = glm::vec3(0.0f), .emission = glm::vec3(2.0f)});
  scene.mesh.add({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 0);
  const LightSampler lights(scene);
  const double point = 14.0, tri = 2.0 * 0.5 * std::numbers::pi;
  EXPECT_NEAR(lights.pmf(0), point / (point + tri), 1e-6);
  EXPECT_NEAR(lights.pmf(1), tri / (point + tri), 1e-6);
  int points = 0;
  constexpr int kN = 100000;
  for (int i = 0; i < kN; ++i) {
    const float u = (static_cast<float>(i) + 0.5f) / kN;
    points += lights.sample(scene, glm::vec3(0.3f, 1.0f, 0.3f), u, {0.5f, 0.5f}).delta;
  }
  EXPECT_NEAR(static_cast<double>(points) / kN, point / (point + tri), 1e-3);
}

bool same_bits(const Image& a, const Image& b) {
  return a.pixels().size() == b.pixels().size() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)) ==
             0;
}

TEST(PathRender, BitIdenticalForAnyThreadCountAndTileSize) {
  const Scene scene = make_cornell_area({.width = 40, .height = 24});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  // 20 spp: two whole blocks of 8, which pair, and a partial block added from the right.
  const Image want = render(scene, accel, pt, {.threads = 1, .tile_size = 16, .spp = 20});
  for (int threads : {1, 2, 5}) {
    for (int tile : {16, 7, 5, 1}) {
      const Image got =
          render(scene, accel, pt, {.threads = threads, .tile_size = tile, .spp = 20});
      EXPECT_TRUE(same_bits(want, got)) << threads << " threads, tile " << tile;
    }
  }
  const BruteForceAccel brute(scene.mesh, kDefaultKernel);
  EXPECT_TRUE(same_bits(want, render(scene, brute, pt, {.spp = 20})))
      << "brute force and the BVH return the same hits, so the same image";
}

TEST(PathRender, DiffuseFastPathGivesTheGeneralPathsImage) {
  // Scenes of plain diffuse materials take a version of the path tracer without the branches for
  // glossy materials, textures, vertex normals and instances. A material that no triangle uses
  // sends the same scene down the general version: same hits, same random numbers, so the image
  // must be the same to the bit.
  const Scene plain = make_cornell_area({.width = 40, .height = 24});
  Scene general = plain;
  Material unused;
  unused.type = MaterialType::kConductor;
  general.materials.push_back(unused);
  const BvhAccel accel(plain.mesh, kDefaultKernel);
  const Image want = render(plain, accel, PathIntegrator(plain), {.spp = 16});
  const Image got = render(general, accel, PathIntegrator(general), {.spp = 16});
  EXPECT_TRUE(same_bits(want, got));
  double sum = 0.0;
  for (const glm::vec3& p : want.pixels()) sum += p.x + p.y + p.z;
  EXPECT_GT(sum, 0.0) << "the comparison must be of an image with something in it";
}

// What cornell-area's axis-aligned walls and single light leave out, for the SIMD lanes' tests:
// a faceted sphere, a tilted blocker, two lights, one tilted and two-sided, seen from both sides.
Scene lanes_scene() {
  const std::string text = R"({"camera": {"position": [0, -0.2, -2.4], "look_at": [0, 0.2, 0],
      "up": [0, -1, 0], "vertical_fov": 50, "width": 28, "height": 20},
      "materials": [{"name": "white", "albedo": [0.8, 0.7, 0.6]},
        {"name": "red", "albedo": [0.7, 0.2, 0.1]},
        {"name": "lamp", "albedo": [0.3, 0.3, 0.3], "emission": [6, 5, 4], "two_sided": true},
        {"name": "strip", "albedo": [0, 0, 0], "emission": [2, 3, 9]}],
      "meshes": [
        {"positions": [[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]],
         "triangles": [[0, 1, 2], [0, 2, 3]], "material": "white"},
        {"positions": [[-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]],
         "triangles": [[0, 1, 2], [0, 2, 3]], "material": "white"},
        {"positions": [[-0.5, 0.2, 0.1], [0.1, 0.5, -0.3], [0.4, 0.0, 0.6], [-0.2, -0.3, 0.7]],
         "triangles": [[0, 1, 2], [0, 2, 3]], "material": "red"},
        {"positions": [[0.3, -0.9, 0.2], [0.8, -0.5, 0.5], [0.5, -0.95, 0.8]],
         "triangles": [[0, 1, 2]], "material": "lamp"},
        {"positions": [[-0.9, -0.8, -0.2], [-0.6, -0.8, 0.6], [-0.7, -0.6, 0.1]],
         "triangles": [[0, 1, 2]], "material": "strip"},
        {"file": "sphere.obj", "material": "white",
         "transform": {"scale": 0.3, "translate": [-0.3, 0.7, 0.4]}}]})";
  LoadedScene loaded =
      parse_scene_json(text, std::string(TRITRACE_SOURCE_DIR) + "/scenes/models/lanes.json");
  apply_overrides(loaded, {});
  return std::move(loaded.scene);
}

// The same scene with an unused conductor among its materials: the path tracer then takes its
// general scalar code, the lanes' reference.
Scene general_version(const Scene& plain) {
  Scene general = plain;
  Material unused;
  unused.type = MaterialType::kConductor;
  general.materials.push_back(unused);
  return general;
}

TEST(PathRender, DiffuseLanesGiveTheGeneralPathsImageUnderTiltedTwoSidedLights) {
  // Diffuse scenes lit by emissive triangles alone shade their vertices eight at a time in SIMD
  // lanes (path_integrator.cpp, lanes::), meant to be the scalar code's numbers exactly. Here with
  // what cornell-area's axis-aligned walls and single light leave out: a faceted sphere, a tilted
  // blocker, two lights, one tilted and two-sided, seen from both sides. The scalar code of the
  // general version (an unused conductor sends the scene there) is the reference, to the bit, at
  // depths that stop before, at and long after Russian roulette starts.
  const Scene plain = lanes_scene();
  const Scene general = general_version(plain);
  const BvhAccel accel(plain.mesh, kDefaultKernel);
  for (int depth : {1, 3, 1024}) {
    const PathSettings settings{.max_depth = depth};
    const Image want = render(general, accel, PathIntegrator(general, settings), {.spp = 16});
    const Image got = render(plain, accel, PathIntegrator(plain, settings), {.spp = 16});
    EXPECT_TRUE(same_bits(want, got)) << "max depth " << depth;
    double sum = 0.0;
    for (const glm::vec3& p : want.pixels()) sum += p.x + p.y + p.z;
    EXPECT_GT(sum, 0.0) << "the comparison must be of an image with something in it";
  }
}

// With the albedo, normal and depth AOVs on, the lanes shade the same scene as above: the image
// and every AOV are the general scalar code's, bit for bit (the AOVs of a plain diffuse scene are
// its first hits', written before the lanes run).
TEST(PathRender, DiffuseLanesWithAovsGiveTheGeneralPathsImageAndAovs) {
  const Scene plain = lanes_scene();
  const Scene general = general_version(plain);
  const BvhAccel accel(plain.mesh, kDefaultKernel);
  const AovSet aovs{.albedo = true, .normal = true, .depth = true};
  Film want(28, 20, aovs), got(28, 20, aovs), without(28, 20);
  render_to_film(general, accel, PathIntegrator(general), want, {.threads = 1, .spp = 8});
  render_to_film(plain, accel, PathIntegrator(plain), got, {.threads = 1, .spp = 8});
  render_to_film(plain, accel, PathIntegrator(plain), without, {.threads = 1, .spp = 8});
  EXPECT_TRUE(same_bits(want.resolve(), got.resolve()));
  EXPECT_TRUE(same_bits(without.resolve(), got.resolve()));
  EXPECT_TRUE(same_bits(want.resolve_albedo(), got.resolve_albedo()));
  EXPECT_TRUE(same_bits(want.resolve_normal(), got.resolve_normal()));
  EXPECT_TRUE(same_bits(want.resolve_depth(), got.resolve_depth()));
  double albedo_sum = 0.0, normal_sum = 0.0;
  const Image albedo = got.resolve_albedo(), normal = got.resolve_normal();
  for (const glm::vec3& p : albedo.pixels()) albedo_sum += p.x + p.y + p.z;
  for (const glm::vec3& p : normal.pixels()) normal_sum += std::abs(p.z);
  EXPECT_GT(albedo_sum, 0.0) << "the comparison must be of AOVs with something in them";
  EXPECT_GT(normal_sum, 0.0);
}

TEST(PathRender, SampleRangesAddUpToTheWholeRender) {
  const Scene scene = make_cornell_area({.width = 24, .height = 24});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  Film whole(24, 24), parts(24, 24);
  render_to_film(scene, accel, pt, whole, {.spp = 37, .seed = 5});
  // Frames as the viewer takes them: any lengths, crossing blocks of 8 and their pairings.
  uint32_t at = 0;
  for (uint32_t n : {2u, 1u, 3u, 10u, 5u, 16u}) {
    render_to_film(scene, accel, pt, parts, {.spp = n, .first_sample = at, .seed = 5});
    at += n;
  }
  ASSERT_EQ(at, 37u);
  EXPECT_TRUE(same_bits(whole.resolve(), parts.resolve()));
  EXPECT_TRUE(same_bits(whole.resolve(), render(scene, accel, pt, {.spp = 37, .seed = 5})))
      << "render() folds the same layers without a film";
  Film other_seed(24, 24);
  render_to_film(scene, accel, pt, other_seed, {.spp = 37, .seed = 6});
  EXPECT_FALSE(same_bits(whole.resolve(), other_seed.resolve()));
}

TEST(PathRender, FilmsStartAtAMultipleOf8AndContinueAtTheirEnd) {
  const Scene scene = make_cornell_area({.width = 8, .height = 8});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  Film film(8, 8);
  EXPECT_THROW(render_to_film(scene, accel, pt, film, {.spp = 4, .first_sample = 4}), Error);
  EXPECT_THROW((void)render(scene, accel, pt, {.spp = 4, .first_sample = 12}), Error);
  render_to_film(scene, accel, pt, film, {.spp = 4, .first_sample = 8});
  EXPECT_EQ(film.first_sample(), 8u);
  EXPECT_EQ(film.end_sample(), 12u);
  EXPECT_THROW(render_to_film(scene, accel, pt, film, {.spp = 4, .first_sample = 16}), Error)
      << "a gap";
  EXPECT_THROW(render_to_film(scene, accel, pt, film, {.spp = 4, .first_sample = 8}), Error)
      << "an overlap";
}

TEST(PathRender, TilePartsCoverTheImageOnceAndMatchTheWholeRender) {
  const Scene scene = make_cornell_area({.width = 50, .height = 34});  // 4 x 3 tiles of 16
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  const Image want = render(scene, accel, pt, {.spp = 9});
  Image sum(50, 34);
  for (int part = 0; part < 5; ++part) {
    const Image got = render(scene, accel, pt, {.spp = 9, .tile_part = part, .tile_parts = 5});
    for (int y = 0; y < 34; ++y) {
      for (int x = 0; x < 50; ++x) {
        const int tile = (y / 16) * 4 + x / 16;
        // Tile t belongs to part t % 5; the other parts leave the pixel black.
        if (tile % 5 == part) {
          EXPECT_EQ(std::memcmp(&got.at(x, y), &want.at(x, y), sizeof(glm::vec3)), 0);
          sum.at(x, y) = got.at(x, y);
        } else {
          EXPECT_EQ(got.at(x, y), glm::vec3(0.0f));
        }
      }
    }
  }
  EXPECT_TRUE(same_bits(want, sum));
}

}  // namespace
}  // namespace tritrace

namespace tritrace {
namespace {

// The white furnace per BSDF: a sphere (scenes/models/sphere.obj, 1280 facets) of one material in
// a uniform environment of radiance 1 and nothing else. A surface that conserves energy (diffuse
// albedo 1, a smooth mirror of F0 = 1, smooth glass, whose radiance scaling by 1/eta^2 going in
// and eta^2 going out cancels) returns 1 from every pixel; rough lobes lose energy between
// microfacets and so never exceed 1.
Scene sphere_in_furnace(const std::string& material_json) {
  const std::string text = R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0],
      "up": [0, -1, 0], "vertical_fov": 30, "width": 24, "height": 24},
      "environment": {"color": [1, 1, 1]},
      "materials": [)" + material_json +
                           R"(], "meshes": [{"file": "sphere.obj", "material": "m"}]})";
  LoadedScene loaded =
      parse_scene_json(text, std::string(TRITRACE_SOURCE_DIR) + "/scenes/models/furnace.json");
  apply_overrides(loaded, {});
  return std::move(loaded.scene);
}

struct FurnaceCase {
  std::string name;
  std::string material;
  bool exact;  // conserves energy: every pixel 1; otherwise at most 1
  double pixel_tolerance = 0.0;
};

class SphereFurnace : public ::testing::TestWithParam<FurnaceCase> {};

TEST_P(SphereFurnace, ReturnsOneOrLessAtEveryPixel) {
  const FurnaceCase& c = GetParam();
  const Scene scene = sphere_in_furnace(c.material);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const Image image = render(scene, accel, integrator, {.spp = 64, .seed = 3});
  const PixelStats s = stats_against(image, 1.0);
  const double se = s.pixel_sd / std::sqrt(static_cast<double>(image.pixels().size()));
  ::testing::Test::RecordProperty("mean", std::to_string(s.mean));
  if (c.exact) {
    EXPECT_LT(std::abs(s.mean - 1.0), 4.0 * se + 1e-5) << "mean " << s.mean << " se " << se;
    // Diffuse, the mirror and index-1 glass reflect or pass exactly 1 at every bounce: no noise
    // at all (diffuse light-samples the environment with the bounce's own cosine density, so the
    // two MIS weights are 1/2 each and each half brings exactly 1/2). Glass scatters
    // with weight 1/eta^2 in, eta^2 out, and Russian roulette adds noise; a tolerance of a quarter
    // still catches a pixel that loses or gains a factor (1/eta^2 = 0.44, eta^2 = 2.25).
    for (const glm::vec3& p : image.pixels()) {
      EXPECT_NEAR((p.x + p.y + p.z) / 3.0, 1.0, c.pixel_tolerance);
    }
  } else {
    // Single-scattering GGX loses energy, so at most 1; how much each lobe returns is checked
    // against quadrature on a plane (furnace_albedo_test.cpp), where one scattering is all.
    EXPECT_LT(s.mean, 1.0 + 4.0 * se) << "mean " << s.mean << " se " << se;
    EXPECT_GT(s.mean, 0.5);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Materials, SphereFurnace,
    ::testing::Values(
        FurnaceCase{"diffuse", R"({"name": "m", "albedo": [1, 1, 1]})", true, 1e-5},
        FurnaceCase{"mirror", R"({"name": "m", "type": "conductor", "albedo": [1, 1, 1]})", true,
                    1e-5},
        FurnaceCase{"glass", R"({"name": "m", "type": "dielectric", "ior": 1.5})", true, 0.25},
        // Rough glass of index 1: no microfacet reflects or bends light, the sphere is invisible.
        FurnaceCase{"rough_index_1",
                    R"({"name": "m", "type": "dielectric", "roughness": 0.5, "ior": 1})", true,
                    1e-5},
        FurnaceCase{"rough_metal",
                    R"({"name": "m", "type": "conductor", "albedo": [1, 1, 1], "roughness": 0.6})",
                    false},
        FurnaceCase{"rough_glass", R"({"name": "m", "type": "dielectric", "roughness": 0.5})",
                    false},
        FurnaceCase{"principled",
                    R"({"name": "m", "type": "principled", "albedo": [1, 1, 1], "roughness": 0.5,
                        "metallic": 0.3, "transmission": 0.3})",
                    false}),
    [](const auto& info) { return info.param.name; });

// The environment is what escaping rays see: an empty view is its colour exactly.
TEST(PathEnvironment, CameraRaysThatMissSeeTheEnvironment) {
  Scene scene = sphere_in_furnace(R"({"name": "m", "albedo": [0, 0, 0]})");
  scene.environment = glm::vec3(0.25f, 0.5f, 2.0f);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const Image image = render(scene, accel, integrator, {.spp = 4, .seed = 1});
  EXPECT_EQ(image.at(0, 0), glm::vec3(0.25f, 0.5f, 2.0f));  // a corner: no sphere there
  EXPECT_EQ(image.at(12, 12), glm::vec3(0.0f));             // the black sphere's centre
}

// Environment maps (issue 12): a map is a light, sampled by its luminance and combined with the
// BSDFs' sampling by MIS; the same tests as for emissive triangles, under a map.
std::shared_ptr<EnvironmentMap> environment_map(int w, int h,
                                                const std::function<glm::vec3(int, int)>& texel) {
  auto m = std::make_shared<EnvironmentMap>();
  m->width = w;
  m->height = h;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) m->texels.push_back(texel(x, y));
  }
  return m;
}

Scene sphere_under_map(const std::string& material_json, std::shared_ptr<EnvironmentMap> map) {
  Scene scene = sphere_in_furnace(material_json);
  scene.environment = glm::vec3(0.0f);
  scene.environment_map = std::move(map);
  return scene;
}

// A white furnace through the scene file: a map FILE of constant radiance 0.5 (written here as
// Radiance HDR and as OpenEXR) around a diffuse sphere of albedo 1 gives 0.5 at every pixel. Light
// sampling of the map takes part (MIS), so pixels are noisy: the worst was 0.0063 off at 256 spp;
// a tolerance of 0.05 leaves room and still catches a strategy lost or counted twice (0.25 on
// every sphere pixel), and the image mean is held to 4 standard errors.
class PathEnvironmentFiles : public ::testing::TestWithParam<std::string> {};

TEST_P(PathEnvironmentFiles, ConstantMapFileIsAFurnace) {
  namespace fs = std::filesystem;
  std::string pattern = (fs::temp_directory_path() / "tritrace-env-furnace-XXXXXX").string();
  ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
  const fs::path dir = pattern;
  Image constant(8, 4);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 8; ++x) constant.at(x, y) = glm::vec3(0.5f);
  }
  const std::string file = (dir / ("sky." + GetParam())).string();
  if (GetParam() == "hdr") {
    write_radiance_hdr(constant, file);
  } else {
    write_exr(constant, file);
  }
  const std::string text = R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0],
      "up": [0, -1, 0], "vertical_fov": 30, "width": 24, "height": 24},
      "environment": {"file": ")" +
                           file + R"("},
      "materials": [{"name": "m", "albedo": [1, 1, 1]}],
      "meshes": [{"file": ")" +
                           std::string(TRITRACE_SOURCE_DIR) +
                           R"(/scenes/models/sphere.obj", "material": "m"}]})";
  LoadedScene loaded = parse_scene_json(text, (dir / "scene.json").string());
  apply_overrides(loaded, {});
  fs::remove_all(dir);
  const Scene& scene = loaded.scene;
  ASSERT_TRUE(scene.environment_map);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const Image image = render(scene, accel, integrator, {.spp = 256, .seed = 4});
  const PixelStats s = stats_against(image, 0.5);
  const double se = s.pixel_sd / std::sqrt(static_cast<double>(image.pixels().size()));
  EXPECT_LT(std::abs(s.mean - 0.5), 4.0 * se + 1e-5) << "mean " << s.mean << " se " << se;
  double worst = 0.0;
  for (const glm::vec3& p : image.pixels()) {
    worst = std::max(worst, std::abs((p.x + p.y + p.z) / 3.0 - 0.5));
  }
  ::testing::Test::RecordProperty("worst_pixel_error", std::to_string(worst));
  EXPECT_LT(worst, 0.05);
}

INSTANTIATE_TEST_SUITE_P(Formats, PathEnvironmentFiles, ::testing::Values("hdr", "exr"));

// A map with a gradient and a bright patch: MIS, light sampling alone and BSDF sampling alone
// agree for every material type, the rough lobes included.
class PathEnvironmentStrategies : public ::testing::TestWithParam<std::string> {};

TEST_P(PathEnvironmentStrategies, MisLightOnlyAndBsdfOnlyAgree) {
  const auto map = environment_map(32, 16, [](int x, int y) {
    if (x >= 20 && x < 24 && y >= 4 && y < 7) return glm::vec3(12.0f, 10.0f, 8.0f);
    return glm::vec3(0.1f + 0.02f * x, 0.2f + 0.05f * y, 0.4f);
  });
  const Scene scene = sphere_under_map(GetParam(), map);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BlockMeans mis = block_means(scene, accel, {.strategy = Strategy::kMis}, 900, 16);
  const BlockMeans light = block_means(scene, accel, {.strategy = Strategy::kLightOnly}, 1000, 16);
  const BlockMeans bsdf = block_means(scene, accel, {.strategy = Strategy::kBsdfOnly}, 1100, 16);
  EXPECT_GT(expect_agree(mis, light, "map: mis vs light only"), 5);
  EXPECT_GT(expect_agree(mis, bsdf, "map: mis vs bsdf only"), 5);
}

constexpr const char* kEnvironmentMaterialNames[] = {"diffuse", "rough_metal", "rough_glass",
                                                     "principled"};

INSTANTIATE_TEST_SUITE_P(
    Materials, PathEnvironmentStrategies,
    ::testing::Values(
        R"({"name": "m", "albedo": [0.8, 0.8, 0.8]})",
        R"({"name": "m", "type": "conductor", "albedo": [1, 0.8, 0.4], "roughness": 0.4})",
        R"({"name": "m", "type": "dielectric", "roughness": 0.5})",
        R"({"name": "m", "type": "principled", "albedo": [0.6, 0.3, 0.2], "roughness": 0.5,
            "metallic": 0.3, "transmission": 0.3})"),
    [](const auto& info) { return std::string(kEnvironmentMaterialNames[info.index]); });

// The mean of the sphere's left and right halves of the image (the sphere covers the middle).
std::pair<double, double> left_and_right(const Image& image) {
  double left = 0.0, right = 0.0;
  const int w = image.width(), h = image.height();
  for (int y = h / 4; y < 3 * h / 4; ++y) {
    for (int x = w / 4; x < 3 * w / 4; ++x) {
      const glm::vec3 p = image.at(x, y);
      (x < w / 2 ? left : right) += (p.x + p.y + p.z) / 3.0;
    }
  }
  return {left, right};
}

// A bright spot in the map's centre column (+z: behind the sphere, seen from the camera at -z):
// rotated by 90 degrees it moves to +x and lights the sphere's right side (image x grows along
// +x), by -90 degrees to -x, the left side. Scale multiplies the image, exactly for a power of 2.
TEST(PathEnvironmentMap, RotateAndScaleDoWhatTheDocsSay) {
  const auto spot = [](float rotate, float scale) {
    auto m = environment_map(32, 16, [](int x, int y) {
      return x >= 15 && x < 17 && y >= 7 && y < 9 ? glm::vec3(50.0f) : glm::vec3(0.0f);
    });
    m->rotate_degrees = rotate;
    m->scale = scale;
    return m;
  };
  const auto image_of = [](const std::shared_ptr<EnvironmentMap>& map) {
    const Scene scene = sphere_under_map(R"({"name": "m", "albedo": [0.8, 0.8, 0.8]})", map);
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    const PathIntegrator integrator(scene);
    return render(scene, accel, integrator, {.spp = 16, .seed = 5});
  };
  const auto [l90, r90] = left_and_right(image_of(spot(90.0f, 1.0f)));
  const auto [lm90, rm90] = left_and_right(image_of(spot(-90.0f, 1.0f)));
  EXPECT_GT(r90, 5.0 * l90);
  EXPECT_GT(lm90, 5.0 * rm90);
  const Image once = image_of(spot(90.0f, 1.0f));
  const Image twice = image_of(spot(90.0f, 2.0f));
  for (size_t i = 0; i < once.pixels().size(); ++i) {
    EXPECT_EQ(twice.pixels()[i], 2.0f * once.pixels()[i]) << "pixel " << i;
  }
}

// Camera rays that miss see the map at their direction: the view's corner pixels lie towards the
// map's columns around +z.
TEST(PathEnvironmentMap, CameraRaysThatMissSeeTheMap) {
  const auto map = environment_map(
      4, 2, [](int x, int y) { return glm::vec3(float(x + 1), float(y + 1), 0.5f); });
  Scene scene = sphere_under_map(R"({"name": "m", "albedo": [0, 0, 0]})", map);
  // A 60 degree view, so that the corner pixels miss the sphere entirely.
  scene.camera = Camera::look_at(24, 24, {0.0f, 0.0f, -3.0f}, {0.0f, 0.0f, 0.0f},
                                 {0.0f, -1.0f, 0.0f}, Camera::focal_for_vertical_fov(24, 60.0));
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const Image image = render(scene, accel, integrator, {.spp = 4, .seed = 1});
  // Top left: above the horizon (row 0), left of +z (u < 0.5: column 1); bottom right: below the
  // horizon (row 1), right of +z (column 2).
  EXPECT_EQ(image.at(0, 0), glm::vec3(2.0f, 1.0f, 0.5f));
  EXPECT_EQ(image.at(23, 23), glm::vec3(3.0f, 2.0f, 0.5f));
  EXPECT_EQ(image.at(12, 12), glm::vec3(0.0f));
}

// ---- The AOVs: albedo and normal of the first non-specular hit, depth of the first hit, and the
// variance of each pixel's mean from the halves of its samples split by sample index parity.

// A quad [x0, x1] x [y0, y1] at z (facing -z), or [x0, x1] x [z0, z1] at y (facing +y).
void add_quad_at_z(TriangleMesh& mesh, float x0, float x1, float y0, float y1, float z,
                   uint32_t m) {
  mesh.add({x0, y0, z}, {x1, y0, z}, {x1, y1, z}, m);
  mesh.add({x0, y0, z}, {x1, y1, z}, {x0, y1, z}, m);
}
void add_quad_at_y(TriangleMesh& mesh, float x0, float x1, float z0, float z1, float y,
                   uint32_t m) {
  mesh.add({x0, y, z0}, {x1, y, z0}, {x1, y, z1}, m);
  mesh.add({x0, y, z0}, {x1, y, z1}, {x0, y, z1}, m);
}

// Mean of an image's channel c over all pixels.
double image_mean(const Image& image, int c) {
  double sum = 0.0;
  for (const glm::vec3& p : image.pixels()) sum += p[c];
  return sum / static_cast<double>(image.pixels().size());
}

// A floor (y = 0, world y up here) that is a perfect white mirror (Schlick's F0 = 1: F = 1 at
// every angle, so the specular tint is exactly 1) and a diffuse wall at z = 5 above it; the camera
// at (0, 1, 0) looks down at the floor, whose every pixel reflects the wall: the albedo AOV is the
// wall's albedo, the normal the wall's facing the reflected ray (0, 0, -1), and depth the
// distance to the mirror (the first hit), sqrt(5) along the centre ray to (0, 0, 2).
TEST(PathAovs, MirrorFloorShowsTheReflectedWall) {
  Scene scene;
  const glm::vec3 wall_albedo(0.2f, 0.5f, 0.7f);
  scene.materials = {
      Material{.albedo = glm::vec3(1.0f), .type = MaterialType::kConductor, .roughness = 0.0f},
      Material{.albedo = wall_albedo}};
  add_quad_at_y(scene.mesh, -10.0f, 10.0f, -10.0f, 10.0f, 0.0f, 0);
  add_quad_at_z(scene.mesh, -10.0f, 10.0f, 0.0f, 20.0f, 5.0f, 1);
  scene.camera = Camera::look_at(16, 16, {0.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 2.0f}, {0.0f, 1.0f, 0.0f},
                                 Camera::focal_for_vertical_fov(16, 20.0));
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  Film film(16, 16, AovSet{.albedo = true, .normal = true, .depth = true});
  render_to_film(scene, accel, pt, film, {.threads = 1, .spp = 8});
  const Image albedo = film.resolve_albedo(), normal = film.resolve_normal();
  const Image depth = film.resolve_depth();
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(albedo.at(x, y)[c], wall_albedo[c], 1e-6f) << x << "," << y;
        EXPECT_NEAR(normal.at(x, y)[c], glm::vec3(0.0f, 0.0f, -1.0f)[c], 1e-6f) << x << "," << y;
      }
    }
  }
  // Pixels (7, 7) to (8, 8) surround the centre ray; the first hit is on the floor, between the
  // distances of the rays 1 pixel above and below the centre (f = 8 / tan 10 deg).
  const double f = 8.0 / std::tan(10.0 * std::numbers::pi / 180.0);
  const double centre = std::atan(0.5);  // below the horizon
  const double near = 1.0 / std::sin(centre + std::atan(1.0 / f));
  const double far = 1.0 / std::sin(centre - std::atan(1.0 / f));
  EXPECT_GT(depth.at(8, 8).x, near * 0.999);
  EXPECT_LT(depth.at(7, 7).x, far * 1.001);
  EXPECT_NEAR(depth.at(8, 8).x, std::sqrt(5.0), far - near);
}

// A smooth glass slab (index 1.5, transmission tint c) between the camera and a diffuse wall, seen
// at near-normal incidence (a 6 degree field of view), where a face reflects F = ((1.5 - 1) /
// (1.5 + 1))^2 = 0.04. The albedo AOV follows the path's own choice at each face: out through
// both faces (tint c^2, the 1/eta^2 and eta^2 of the crossing cancelled) to the wall, or back to
// the camera (escapes: 0), with any even number of reflections inside: its mean is
// a c^2 (1 - F)^2 (1 + F^2 + F^4 + ...) = a c^2 (1 - F) / (1 + F).
TEST(PathAovs, SmoothGlassShowsTheWallBehindItTinted) {
  Scene scene;
  const glm::vec3 wall_albedo(0.6f, 0.4f, 0.2f), tint(0.5f, 0.8f, 1.0f);
  scene.materials = {
      Material{.albedo = tint, .type = MaterialType::kDielectric, .roughness = 0.0f, .ior = 1.5f},
      Material{.albedo = wall_albedo}};
  add_quad_at_z(scene.mesh, -10.0f, 10.0f, -10.0f, 10.0f, 2.0f, 0);
  add_quad_at_z(scene.mesh, -10.0f, 10.0f, -10.0f, 10.0f, 2.5f, 0);
  add_quad_at_z(scene.mesh, -10.0f, 10.0f, -10.0f, 10.0f, 5.0f, 1);
  constexpr int kSide = 32;
  constexpr uint32_t kSpp = 16;
  scene.camera = Camera::look_at(kSide, kSide, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f},
                                 {0.0f, 1.0f, 0.0f}, Camera::focal_for_vertical_fov(kSide, 6.0));
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  Film film(kSide, kSide, AovSet{.albedo = true, .depth = true});
  render_to_film(scene, accel, pt, film, {.threads = 1, .spp = kSpp});
  const double r = 0.04, through = (1.0 - r) / (1.0 + r);
  // Each sample's albedo is a c^2 with probability about p = through, else (nearly always) 0:
  // the standard error of the mean of N samples is a c^2 sqrt(p (1 - p) / N). Russian roulette
  // (from the third bounce on) may end a path after two reflections inside, leaving the glass's
  // own provisional values: at most F^2 = 0.0016 of the mean's weight.
  const double n = static_cast<double>(kSide * kSide) * kSpp;
  const double se = std::sqrt(through * (1.0 - through) / n);
  for (int c = 0; c < 3; ++c) {
    const double full = wall_albedo[c] * tint[c] * tint[c];
    EXPECT_NEAR(image_mean(film.resolve_albedo(), c), full * through, full * (4.0 * se) + r * r)
        << "channel " << c;
  }
  // Depth is the first hit's: the slab's front face, 2 along the axis, at most 2 / cos(theta) at
  // the image's corners, tan(theta) = sqrt(2) tan(3 deg).
  const Image depth = film.resolve_depth();
  const double corner = std::atan(std::sqrt(2.0) * std::tan(3.0 * std::numbers::pi / 180.0));
  for (const glm::vec3& d : depth.pixels()) {
    EXPECT_GE(d.x, 2.0f);
    EXPECT_LE(d.x, 2.0 / std::cos(corner) * 1.0001);
  }
}

// With vertex normals, the normal AOV is the interpolated shading normal, not the facet's: a
// single triangle whose corners' normals all lean the same way shows that normal.
TEST(PathAovs, NormalIsTheShadingNormalWhereTheMeshIsSmooth) {
  Scene scene;
  scene.materials = {Material{.albedo = glm::vec3(0.5f)}};
  const glm::vec3 lean = glm::normalize(glm::vec3(0.3f, 0.0f, -1.0f));
  scene.mesh.add({-10.0f, -10.0f, 3.0f}, {10.0f, -10.0f, 3.0f}, {0.0f, 20.0f, 3.0f}, 0,
                 {lean, lean, lean});
  scene.camera = Camera::look_at(8, 8, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f},
                                 Camera::focal_for_vertical_fov(8, 10.0));
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  Film film(8, 8, AovSet{.normal = true});
  render_to_film(scene, accel, pt, film, {.threads = 1, .spp = 4});
  const Image normal = film.resolve_normal();
  for (const glm::vec3& n : normal.pixels()) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(n[c], lean[c], 1e-5f);
  }
}

// The even half buffer holds the samples of even global index: sample 0 of [0, 2) (its sum is
// the film of [0, 1)'s), also when the film is rendered in calls [0, 1) then [1, 2), where a
// call-local parity would count sample 1 as even; and a film continued call by call ends with the
// bits of one call.
TEST(PathAovs, VarianceHalvesFollowTheGlobalSampleIndex) {
  const Scene scene = make_cornell_area({.width = 8, .height = 8});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  const AovSet variance{.variance = true};
  Film one(8, 8, variance), two(8, 8, variance), stepped(8, 8, variance);
  render_to_film(scene, accel, pt, one, {.spp = 1});
  render_to_film(scene, accel, pt, two, {.spp = 2});
  render_to_film(scene, accel, pt, stepped, {.spp = 1});
  render_to_film(scene, accel, pt, stepped, {.spp = 1, .first_sample = 1});
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      EXPECT_EQ(one.pixel_aov_sums(x, y).even, one.pixel_sums(x, y));
      EXPECT_EQ(two.pixel_aov_sums(x, y).even, one.pixel_sums(x, y));
      EXPECT_EQ(stepped.pixel_aov_sums(x, y).even, one.pixel_sums(x, y));
    }
  }
  Film whole(8, 8, variance), calls(8, 8, variance);
  render_to_film(scene, accel, pt, whole, {.spp = 21});
  for (auto [a, b] :
       {std::pair{0u, 3u}, std::pair{3u, 9u}, std::pair{9u, 16u}, std::pair{16u, 21u}}) {
    render_to_film(scene, accel, pt, calls, {.spp = b - a, .first_sample = a});
  }
  ASSERT_EQ(whole.layer_count(), calls.layer_count());
  for (size_t k = 0; k < whole.layer_count(); ++k) {
    EXPECT_EQ(std::memcmp(whole.aov_sums(k), calls.aov_sums(k), 64 * sizeof(AovSums)), 0) << k;
  }
  EXPECT_TRUE(same_bits(whole.resolve_variance(), calls.resolve_variance()));
}

// The half-buffer estimate of the variance of a pixel's mean agrees with the spread of that mean
// over independent renders (independent samples: Sobol's halves are stratified together, and the
// estimate is then conservative). Per seed r, X_r = sum over pixels and channels of the estimate
// minus R / (R - 1) (m_r - mean m)^2: their mean is the sum of the estimates minus the sum of the
// sample variances over seeds, which must be zero within 4 standard errors of the X_r. The same
// test with the estimate's 1/4 left out fails by far (a ratio of 4).
TEST(PathAovs, HalfBufferVarianceMatchesTheSpreadOfIndependentRenders) {
  const Scene scene = make_cornell_area({.width = 8, .height = 8});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const PathIntegrator pt(scene);
  constexpr int kSeeds = 48;
  constexpr size_t kValues = 8 * 8 * 3;
  std::vector<std::vector<double>> means(kSeeds), estimates(kSeeds);
  std::vector<double> average(kValues, 0.0);
  for (int r = 0; r < kSeeds; ++r) {
    Film film(8, 8, AovSet{.variance = true});
    render_to_film(
        scene, accel, pt, film,
        {.spp = 16, .seed = static_cast<uint64_t>(r + 1), .sampler = SamplerKind::kIndependent});
    const Image image = film.resolve(), variance = film.resolve_variance();
    for (size_t p = 0; p < 64; ++p) {
      for (int c = 0; c < 3; ++c) {
        means[r].push_back(image.pixels()[p][c]);
        estimates[r].push_back(variance.pixels()[p][c]);
        average[p * 3 + static_cast<size_t>(c)] += image.pixels()[p][c] / kSeeds;
      }
    }
  }
  std::vector<double> x(kSeeds, 0.0);
  double estimated = 0.0, observed = 0.0;
  for (int r = 0; r < kSeeds; ++r) {
    for (size_t v = 0; v < kValues; ++v) {
      const double d = means[r][v] - average[v];
      const double spread = d * d * kSeeds / (kSeeds - 1.0);
      x[r] += estimates[r][v] - spread;
      estimated += estimates[r][v] / kSeeds;
      observed += spread / kSeeds;
    }
  }
  double mean_x = 0.0, var_x = 0.0;
  for (double v : x) mean_x += v / kSeeds;
  for (double v : x) var_x += (v - mean_x) * (v - mean_x) / (kSeeds - 1.0);
  const double se = std::sqrt(var_x / kSeeds);
  EXPECT_GT(observed, 0.0);
  EXPECT_LT(std::abs(mean_x), 4.0 * se)
      << "estimated " << estimated << ", observed " << observed << ", se " << se;
  EXPECT_LT(std::abs(estimated / observed - 1.0), 0.5) << "and not far off as a ratio";
}

}  // namespace
}  // namespace tritrace
