// The bidirectional path tracer against oracles that do not use it: white furnaces (radiance
// Le / (1 - a) everywhere; 1 under a uniform environment), the path tracer's images of the same
// scenes (cornell-area, the lab's point-light box, glass and rough metal in the box, principled
// materials, instances, environments, an emitter shut inside a glass cube, whose
// light leaves through delta refractions: the adjoint's classic 1/eta^2 mistake would show), the
// strategies against each other (each alone, unweighted, estimates the same paths; weighted, they
// add up to the whole image), and images independent of threads and tiles.
#include "example_scene.h"
#include "mean_and_error.h"
#include "tritrace/render/bdpt_integrator.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/error.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

using testing_mc::luminance_mean;
using testing_scenes::example_scene;

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
  // The measured agreement, for the record (docs/BDPT.md quotes these lines).
  std::printf("  means %.5f / %.5f (ratio %.4f), %d of %d blocks within %.2f, worst %.4f\n", ma, mb,
              ma / mb, good, bw * bh, block_tolerance, worst);
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

// Albedo 0.9 makes paths of tens of vertices, beyond the subpaths' first allocation (16).
class BdptFurnace : public ::testing::TestWithParam<float> {};

TEST_P(BdptFurnace, WhiteFurnaceGivesEmissionOverOneMinusAlbedo) {
  const float a = GetParam(), le = 0.75f;
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

INSTANTIATE_TEST_SUITE_P(Albedos, BdptFurnace, ::testing::Values(0.5f, 0.9f));

// Diffuse cornell-area, lit by its ceiling triangles: bdpt and path converge to the same image.
TEST(Bdpt, AgreesWithThePathTracerOnCornellArea) {
  const Scene scene = make_cornell_area({.width = 32, .height = 32});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image bdpt = render_bdpt(scene, accel, {}, {.spp = 256, .seed = 1});
  const Image path = render_path(scene, accel, {.spp = 1024, .seed = 2});
  expect_agree(bdpt, path, 0.005, 16, 0.03, 0.99);
}

// The lab's box under its point light (path traced: indirect light is real): bdpt's point light
// is found by its light subpaths (s >= 1) only.
TEST(Bdpt, AgreesWithThePathTracerOnTheLabPointLightBox) {
  const Scene scene = make_cornell_box({.width = 32, .height = 32});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image bdpt = render_bdpt(scene, accel, {}, {.spp = 256, .seed = 1});
  const Image path = render_path(scene, accel, {.spp = 1024, .seed = 2});
  expect_agree(bdpt, path, 0.005, 16, 0.03, 0.99);
}

bool same_bits(const Image& a, const Image& b) {
  return a.width() == b.width() && a.height() == b.height() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)) ==
             0;
}

// Each sample is a function of (seed, pixel, sample index), and light tracing's splats are
// integer sums that no order of addition changes: the image is the same bit for bit for any
// thread count and tile size.
TEST(Bdpt, BitIdenticalForAnyThreadCountAndTileSize) {
  const Scene scene = make_cornell_box({.width = 24, .height = 20});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene);
  const Image want = render(scene, accel, bdpt, {.threads = 1, .tile_size = 16, .spp = 8});
  for (int threads : {2, 3}) {
    for (int tile : {1, 5, 16}) {
      const Image got =
          render(scene, accel, bdpt, {.threads = threads, .tile_size = tile, .spp = 8});
      EXPECT_TRUE(same_bits(want, got)) << threads << " threads, tile " << tile;
    }
  }
}

// The camera walk's flat Lambert vertices scatter eight to a SIMD operation where the build has
// AVX2: the image is the scalar walk's bit for bit, on cornell-area (with and without a light
// subpath in every sample) and in the furnace, whose paths run long enough for roulette.
TEST(Bdpt, WalkLanesGiveTheScalarWalksImage) {
  const Scene cornell = make_cornell_area({.width = 24, .height = 20});
  const BvhAccel cornell_accel(cornell.mesh, kDefaultKernel);
  const RenderOptions options{.threads = 1, .spp = 8};
  for (const float share : {1.0f, 0.125f}) {
    const Image lanes = render_bdpt(cornell, cornell_accel, {.light_paths = share}, options);
    const Image scalar =
        render_bdpt(cornell, cornell_accel, {.light_paths = share, .lanes = false}, options);
    EXPECT_TRUE(same_bits(lanes, scalar)) << "light_paths " << share;
  }
  const Scene box = furnace(0.9f, 0.5f, 12);
  const BvhAccel box_accel(box.mesh, kDefaultKernel);
  EXPECT_TRUE(same_bits(render_bdpt(box, box_accel, {}, {.threads = 1, .spp = 4}),
                        render_bdpt(box, box_accel, {.lanes = false}, {.threads = 1, .spp = 4})));
}

// Samples whose light subpath is its first vertex only (at light_paths 1/8 most of them; at 1
// those whose light subpath ends there) connect s = 0 and s = 1 by their own code, each weighted as
// it is made and s = 1 at flat Lambert vertices eight to a SIMD operation: the image is the
// general code's bit for bit, with the scalar walk too (lanes off: the dedicated code's scalar
// connections), with the balance heuristic, without weights, and in the furnace (long paths).
TEST(Bdpt, CameraOnlyConnectionsGiveTheGeneralCodesImage) {
  const Scene cornell = make_cornell_area({.width = 24, .height = 20});
  const BvhAccel cornell_accel(cornell.mesh, kDefaultKernel);
  const RenderOptions options{.threads = 1, .spp = 8};
  for (const float share : {1.0f, 0.125f}) {
    for (const bool lanes : {true, false}) {
      for (const int variant : {0, 1, 2}) {
        BdptSettings fast{.light_paths = share, .lanes = lanes};
        fast.balance = variant == 1;
        fast.unweighted = variant == 2;
        BdptSettings general = fast;
        general.camera_only_connect = false;
        EXPECT_TRUE(same_bits(render_bdpt(cornell, cornell_accel, fast, options),
                              render_bdpt(cornell, cornell_accel, general, options)))
            << "light_paths " << share << " lanes " << lanes << " variant " << variant;
      }
    }
  }
  const Scene box = furnace(0.9f, 0.5f, 12);
  const BvhAccel box_accel(box.mesh, kDefaultKernel);
  EXPECT_TRUE(
      same_bits(render_bdpt(box, box_accel, {.light_paths = 0.125f}, {.threads = 1, .spp = 4}),
                render_bdpt(box, box_accel, {.light_paths = 0.125f, .camera_only_connect = false},
                            {.threads = 1, .spp = 4})));
}

using testing_mc::expect_same_mean;
using testing_mc::mean_of_renders;
using testing_mc::MeanAndError;

// --max-depth means what it means for the path tracer: 0 is the emitters the camera sees (the
// same image to the bit: same camera samples, Le with weight 1), 1 adds light reaching the first
// hit directly (the same image in expectation; with the point light of the lab's box as well).
TEST(Bdpt, MaxDepthCountsBouncesAsThePathTracerDoes) {
  const Scene scene = make_cornell_area({.width = 32, .height = 32});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  PathSettings path_settings;
  path_settings.max_depth = 0;
  const Image path0 = render(scene, accel, PathIntegrator(scene, path_settings), {.spp = 4});
  EXPECT_TRUE(same_bits(render_bdpt(scene, accel, {.max_depth = 0}, {.spp = 4}), path0));
  EXPECT_GT(luminance_mean(path0), 0.0);
  path_settings.max_depth = 1;
  for (const Scene& s : {scene, make_cornell_box({.width = 32, .height = 32})}) {
    const BvhAccel a(s.mesh, kDefaultKernel);
    const Image bdpt = render_bdpt(s, a, {.max_depth = 1}, {.spp = 256, .seed = 1});
    const Image path = render(s, a, PathIntegrator(s, path_settings), {.spp = 512, .seed = 2});
    expect_agree(bdpt, path, 0.005, 16, 0.03, 0.99);
  }
}

// A closed cube of smooth glass (index 1.5) in cornell-area without its ceiling
// light, with a two-sided emitter inside: every path leaves the emitter through one or more delta
// refractions. Light subpaths carry importance through them, which refraction does not scale;
// radiance's 1/eta^2 there (the classic mistake) would make bdpt's light-subpath strategies
// 2.25 times too bright.
Scene emitter_in_glass(int side) {
  Scene scene = make_cornell_area({.width = side, .height = side});
  for (Material& m : scene.materials) {
    if (m.emits()) m.emission = glm::vec3(0.0f);
  }
  const auto glass = static_cast<uint32_t>(scene.materials.size());
  scene.materials.push_back({.albedo = glm::vec3(1.0f), .type = MaterialType::kDielectric});
  const auto lamp = static_cast<uint32_t>(scene.materials.size());
  scene.materials.push_back(
      {.albedo = glm::vec3(0.0f), .emission = glm::vec3(8.0f), .two_sided = true});
  // Floating above the short block (top at y = 0.405; world y points down), clear of the tall one.
  const glm::vec3 c(0.35f, 0.1f, -0.4f);
  const float h = 0.25f;
  // Each face as two triangles wound so that the lab normal cross(e2, e1) points out of the cube
  // (the dielectric's inside is opposite its lab normal).
  const auto face = [&](glm::vec3 n, glm::vec3 u, glm::vec3 v) {
    const glm::vec3 o = c + h * n;
    glm::vec3 p[4] = {o - h * u - h * v, o + h * u - h * v, o + h * u + h * v, o - h * u + h * v};
    const auto add = [&](glm::vec3 a, glm::vec3 b, glm::vec3 d) {
      const glm::vec3 lab = glm::cross(d - a, b - a);
      if (glm::dot(lab, n) > 0.0f) {
        scene.mesh.add(a, b, d, glass);
      } else {
        scene.mesh.add(a, d, b, glass);
      }
    };
    add(p[0], p[1], p[2]);
    add(p[0], p[2], p[3]);
  };
  const glm::vec3 x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
  face(x, y, z);
  face(-x, y, z);
  face(y, x, z);
  face(-y, x, z);
  face(z, x, y);
  face(-z, x, y);
  const float l = 0.1f;
  scene.mesh.add(c + glm::vec3(-l, 0, -l), c + glm::vec3(l, 0, -l), c + glm::vec3(l, 0, l), lamp);
  scene.mesh.add(c + glm::vec3(-l, 0, -l), c + glm::vec3(l, 0, l), c + glm::vec3(-l, 0, l), lamp);
  return scene;
}

TEST(Bdpt, AgreesWithThePathTracerOnAnEmitterInsideGlass) {
  const Scene scene = emitter_in_glass(16);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  expect_same_mean(mean_of_renders(scene, accel, BdptIntegrator(scene), 128, 30, 8),
                   mean_of_renders(scene, accel, PathIntegrator(scene), 512, 40, 8), 0.03);
}

// A lamp behind a pane of smooth glass: cornell-area without its ceiling light, a one-sided
// emitter facing down just under the ceiling, and below it a large horizontal pane whose inside
// (index 1.5) is the lamp's side. The camera looks down at the floor from below the pane, so it
// never sees the pane or the lamp: the paths of five vertices that carry light are camera,
// diffuse, diffuse, then either the pane and the lamp (E D D S L) or the lamp directly beside the
// pane (E D D D L). Strategy (0, 5) samples them from the camera alone; (3, 2) samples them with a
// light subpath through the pane connected to the camera's first hit. Light subpaths carry
// importance through the refraction, which refraction does not scale: radiance's 1/eta^2 factor
// there (the classic mistake) would make (3, 2) about 2.25 times too bright.
Scene lamp_behind_glass(int side) {
  Scene scene = make_cornell_area({.width = side, .height = side});
  for (Material& m : scene.materials) {
    if (m.emits()) m.emission = glm::vec3(0.0f);
  }
  const auto glass = static_cast<uint32_t>(scene.materials.size());
  scene.materials.push_back({.albedo = glm::vec3(1.0f), .type = MaterialType::kDielectric});
  const auto lamp = static_cast<uint32_t>(scene.materials.size());
  scene.materials.push_back({.albedo = glm::vec3(0.0f), .emission = glm::vec3(10.0f)});
  // A horizontal square at height y (world y points down: the ceiling is y = -1), wound so that
  // its lab normal cross(e2, e1) points down (+y), into the room.
  const auto square = [&](float y, float half, uint32_t material) {
    const glm::vec3 a(-half, y, -half), b(half, y, -half), c(half, y, half), d(-half, y, half);
    const glm::vec3 n = glm::cross(c - a, b - a);
    if (n.y > 0.0f) {
      scene.mesh.add(a, b, c, material);
      scene.mesh.add(a, c, d, material);
    } else {
      scene.mesh.add(a, c, b, material);
      scene.mesh.add(a, d, c, material);
    }
  };
  square(-0.9f, 0.15f, lamp);
  square(-0.8f, 0.6f, glass);
  const float fov = 40.0f;
  scene.camera = Camera::look_at(side, side, {0.0f, -0.3f, -0.95f}, {0.0f, 1.0f, 0.3f},
                                 {0.0f, -1.0f, 0.0f}, Camera::focal_for_vertical_fov(side, fov));
  return scene;
}

TEST(Bdpt, LightSubpathThroughGlassAgreesWithTheCameraSubpath) {
  const Scene scene = lamp_behind_glass(16);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const auto alone = [&](int s, int t, uint32_t spp) {
    const BdptSettings settings{.max_depth = 3, .only_s = s, .only_t = t, .unweighted = true};
    return mean_of_renders(scene, accel, BdptIntegrator(scene, settings), spp, 100, 8);
  };
  // 5%: ample to tell 2.25 (or 1.5) from 1.
  expect_same_mean(alone(3, 2, 32), alone(0, 5, 512), 0.05);
}

// Every strategy alone, weighted by its MIS weight, adds up to the whole image (the weights of
// each path sum to one), here for paths of up to four bounces, light tracing (t = 1) included.
void expect_weighted_strategies_sum_to_the_image(const Scene& scene, float light_paths = 1.0f) {
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const int max_depth = 4;
  const RenderOptions options{.threads = 1, .spp = 8, .seed = 9};
  const Image whole =
      render_bdpt(scene, accel, {.max_depth = max_depth, .light_paths = light_paths}, options);
  std::vector<glm::vec3> sum(whole.pixels().size(), glm::vec3(0.0f));
  // t = 1 is light tracing (s >= 2: an emitter seen directly is (0, 2)'s alone).
  for (int t = 1; t <= max_depth + 2; ++t) {
    for (int s = t == 1 ? 2 : 0; s + t <= max_depth + 2; ++s) {
      const Image part = render_bdpt(
          scene, accel,
          {.max_depth = max_depth, .only_s = s, .only_t = t, .light_paths = light_paths}, options);
      for (size_t i = 0; i < sum.size(); ++i) sum[i] += part.pixels()[i];
    }
  }
  double total = 0.0;
  for (size_t i = 0; i < sum.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(sum[i][c], whole.pixels()[i][c], 1e-4f * (1.0f + whole.pixels()[i][c]))
          << "pixel " << i;
      total += whole.pixels()[i][c];
    }
  }
  EXPECT_GT(total, 0.0);
}

TEST(Bdpt, WeightedStrategiesSumToTheImage) {
  expect_weighted_strategies_sum_to_the_image(make_cornell_area({.width = 12, .height = 12}));
}

// Each strategy that can sample the paths with one bounce between camera and light (four
// vertices) estimates the same image alone, unweighted, on the diffuse cornell-area: the camera
// subpath hitting the light (0, 4), next-event estimation (1, 3), and a light subpath's first
// bounce connected to the camera's first hit (2, 2). (2, 2) alone has unbounded variance near the
// box's edges, where G ~ 1/d^2 between two walls, so its standard error is only an estimate here
// (from 32 renders: with 8, a different draw of the same numbers' dimensions put it at z 4.5 or
// -2.9 by chance); UnweightedEnvironmentStrategiesAgree uses a scene without such edges.
TEST(Bdpt, UnweightedStrategiesOfOneLengthAgree) {
  const Scene scene = make_cornell_area({.width = 16, .height = 16});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const auto alone = [&](int s, int t, uint32_t spp) {
    const BdptSettings settings{.max_depth = 2, .only_s = s, .only_t = t, .unweighted = true};
    return mean_of_renders(scene, accel, BdptIntegrator(scene, settings), spp, 10, 32);
  };
  const MeanAndError nee = alone(1, 3, 32);
  expect_same_mean(alone(2, 2, 32), nee, 0.02);
  expect_same_mean(alone(0, 4, 256), nee, 0.02);
}

// The balance heuristic is unbiased too: the same image mean as the power heuristic's.
TEST(Bdpt, BalanceAndPowerHeuristicsAgree) {
  const Scene scene = make_cornell_area({.width = 16, .height = 16});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const double power = luminance_mean(render_bdpt(scene, accel, {}, {.spp = 256, .seed = 6}));
  const double balance =
      luminance_mean(render_bdpt(scene, accel, {.balance = true}, {.spp = 256, .seed = 7}));
  EXPECT_NEAR(balance / power, 1.0, 0.01);
}

// The wavefronts (docs/BDPT.md): a batch's samples are walked side by side, 64 at a time, their
// shadow rays queued across samples. The oracle is the same samples given one per call, where no
// sample has a neighbour: radiance, AOVs and the light image must be the same bits, for a batch
// of 200 samples (wavefronts of 64, 64, 64 and 8) on a scene with glass (delta vertices, long
// subpaths) and cornell-area.
TEST(Bdpt, BatchOfSamplesIsItsSamplesOneAtATime) {
  for (const bool glass : {true, false}) {
    SCOPED_TRACE(glass ? "glass.json" : "cornell-area");
    const Scene scene =
        glass ? example_scene("glass.json", 16) : make_cornell_area({.width = 16, .height = 16});
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    const BdptIntegrator bdpt(scene);
    constexpr size_t n = 200;
    std::vector<Ray> rays(n);
    std::vector<Sampler> batch_samplers(n, Sampler(7)), one_samplers(n, Sampler(7));
    std::vector<uint32_t> pixels(n);
    for (size_t i = 0; i < n; ++i) {
      const int x = static_cast<int>(i % 16), y = static_cast<int>(i / 16);
      batch_samplers[i].start_pixel_sample(x, y, 3);
      one_samplers[i].start_pixel_sample(x, y, 3);
      const glm::vec2 u = batch_samplers[i].get_pixel_2d();
      one_samplers[i].get_pixel_2d();
      rays[i] = scene.camera.ray_through(static_cast<float>(x) + u.x, static_cast<float>(y) + u.y);
      pixels[i] = static_cast<uint32_t>(y * 16 + x);
    }
    std::vector<glm::vec3> radiance(n), albedo(n), normal(n);
    std::vector<float> depth(n);
    SplatBuffer splats(16, 16);
    bdpt.radiance(SampleBatch{rays, batch_samplers, pixels},
                  SampleOutput{radiance, albedo, normal, depth, &splats}, scene, accel);
    SplatBuffer one_splats(16, 16);
    for (size_t i = 0; i < n; ++i) {
      glm::vec3 r, a, nn;
      float d;
      bdpt.radiance(
          SampleBatch{std::span<const Ray>(&rays[i], 1), std::span<Sampler>(&one_samplers[i], 1),
                      std::span<const uint32_t>(&pixels[i], 1)},
          SampleOutput{std::span<glm::vec3>(&r, 1), std::span<glm::vec3>(&a, 1),
                       std::span<glm::vec3>(&nn, 1), std::span<float>(&d, 1), &one_splats},
          scene, accel);
      ASSERT_EQ(std::memcmp(&r, &radiance[i], sizeof r), 0) << "sample " << i;
      ASSERT_EQ(std::memcmp(&a, &albedo[i], sizeof a), 0) << "sample " << i;
      ASSERT_EQ(std::memcmp(&nn, &normal[i], sizeof nn), 0) << "sample " << i;
      ASSERT_EQ(std::memcmp(&d, &depth[i], sizeof d), 0) << "sample " << i;
    }
    EXPECT_EQ(splats.data(), one_splats.data());
    double sum = 0.0;
    for (const glm::vec3& r : radiance) sum += static_cast<double>(r.x + r.y + r.z);
    EXPECT_GT(sum, 0.0);  // not a vacuous comparison of black samples
    uint64_t nonzero = 0;
    for (uint64_t v : splats.data()) nonzero += v != 0 ? 1 : 0;
    EXPECT_GT(nonzero, 0u);
  }
}

// Glass and rough metal spheres (faceted meshes) in the box: both integrators agree.
TEST(Bdpt, AgreesWithThePathTracerOnGlassAndRoughMetal) {
  for (const char* file : {"glass.json", "rough_metal.json"}) {
    SCOPED_TRACE(file);
    const Scene scene = example_scene(file, 32);
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    const Image bdpt = render_bdpt(scene, accel, {}, {.spp = 128, .seed = 1});
    const Image path = render_path(scene, accel, {.spp = 1024, .seed = 2});
    expect_agree(bdpt, path, 0.01, 16, 0.03, 0.99);
  }
}

// The albedo and normal AOVs (the denoiser's features) are the path tracer's: of the first
// surface that is not specular, seen through smooth glass with its tint. On a diffuse scene the
// same bits; through the glass sphere the same means (the reflect-or-refract choice is each
// integrator's own random number).
TEST(Bdpt, AovsAreThePathTracers) {
  const AovSet aovs{.albedo = true, .normal = true, .depth = true};
  const auto film_of = [&](const Scene& scene, const Integrator& integrator, uint32_t spp) {
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    Film film(scene.camera.width(), scene.camera.height(), aovs);
    render_to_film(scene, accel, integrator, film, {.spp = spp, .seed = 3});
    return film;
  };
  const Scene area = make_cornell_area({.width = 24, .height = 16});
  const Film bdpt = film_of(area, BdptIntegrator(area), 4);
  const Film path = film_of(area, PathIntegrator(area), 4);
  EXPECT_TRUE(same_bits(bdpt.resolve_albedo(), path.resolve_albedo()));
  EXPECT_TRUE(same_bits(bdpt.resolve_normal(), path.resolve_normal()));
  EXPECT_TRUE(same_bits(bdpt.resolve_depth(), path.resolve_depth()));

  const Scene glass = example_scene("glass.json", 32);
  const Image bdpt_albedo = film_of(glass, BdptIntegrator(glass), 64).resolve_albedo();
  const Image path_albedo = film_of(glass, PathIntegrator(glass), 64).resolve_albedo();
  expect_agree(bdpt_albedo, path_albedo, 0.005, 16, 0.03, 0.99);
}

// The principled material's mixes (a half-metallic rough block, a varnished diffuse block with a
// smooth coat: delta and non-delta lobes in one Bsdf) and a rough glass wall, in cornell-area.
TEST(Bdpt, AgreesWithThePathTracerOnPrincipledAndRoughGlass) {
  Scene scene = make_cornell_area({.width = 32, .height = 32});
  const glm::vec3 red(0.75f, 0.15f, 0.15f), blue(0.15f, 0.15f, 0.75f), white(0.75f);
  for (Material& m : scene.materials) {
    if (m.emits()) continue;
    if (m.albedo == red) {
      m.type = MaterialType::kPrincipled;
      m.metallic = 0.5f;
      m.roughness = 0.4f;
    } else if (m.albedo == blue) {
      m.type = MaterialType::kPrincipled;
      m.roughness = 0.0f;  // a smooth (delta) coat over the diffuse base
    } else if (m.albedo == white) {
      m.type = MaterialType::kDielectric;  // the back wall: rough glass, light passes both ways
      m.roughness = 0.3f;
      m.albedo = glm::vec3(0.9f);
    }
  }
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image bdpt = render_bdpt(scene, accel, {}, {.spp = 128, .seed = 1});
  const Image path = render_path(scene, accel, {.spp = 1024, .seed = 2});
  expect_agree(bdpt, path, 0.01, 16, 0.03, 0.99);
}

// cornell-area with every triangle's corner normals bent (smooth shading that disagrees with the
// facets, as instanced_render_test.cpp bends them) and its walls, blocks and light textured:
// shading normals with Veach's adjoint correction on light subpaths, textured albedo and emission.
Scene bent_and_textured(int side, float bend) {
  Scene s = make_cornell_area({.width = side, .height = side});
  TriangleMesh out;
  for (uint32_t i = 0; i < s.mesh.size(); ++i) {
    std::array<glm::vec3, 3> normals;
    std::array<glm::vec2, 3> uvs;
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 p = s.mesh.vertex(i, k);
      normals[static_cast<size_t>(k)] =
          glm::normalize(s.mesh.normal()[i] + bend * glm::sin(3.0f * p));
      uvs[static_cast<size_t>(k)] = glm::vec2(p.x + 0.3f * p.z, p.y - 0.2f * p.z);
    }
    out.add(s.mesh.vertex(i, 0), s.mesh.vertex(i, 1), s.mesh.vertex(i, 2), s.mesh.material()[i],
            &normals, &uvs);
  }
  s.mesh = out;
  TextureImage image{.width = 4, .height = 3, .rgb = {}, .alpha = {}};
  for (int k = 0; k < 36; ++k) image.rgb.push_back(static_cast<uint8_t>(40 + 37 * k % 200));
  s.textures = {Texture::from_srgb8(image)};
  for (Material& m : s.materials) {
    if (m.emits()) {
      m.emission_texture.index = 0;
    } else {
      m.albedo_texture.index = 0;
    }
  }
  return s;
}

// The two shading-normal rules differ where the camera-side direction lies on different sides of
// the shading and geometric surfaces (bdpt carries nothing there, the path tracer shades with the
// geometric normal; docs/BDPT.md): with these bends the difference is below the test's 0.3%
// standard error. A z-test of 8 renders each: one image's mean is too noisy here.
TEST(Bdpt, AgreesWithThePathTracerWithShadingNormalsAndTextures) {
  const Scene scene = bent_and_textured(24, 0.4f);
  ASSERT_TRUE(scene.smooth(0));
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  expect_same_mean(mean_of_renders(scene, accel, BdptIntegrator(scene), 64, 30, 8),
                   mean_of_renders(scene, accel, PathIntegrator(scene), 256, 40, 8), 0.01);
}

// cornell-area with glTF's surface detail: a tangent-space normal map on every reflector (a 2 x 2
// data texture tilting the normal up to about 13 degrees, tangents computed per triangle from the
// texture coordinates) and vertex colours multiplying the albedo. The normal map feeds the same
// shading-normal rules and adjoint correction as vertex normals do, so the two integrators agree.
TEST(Bdpt, AgreesWithThePathTracerWithNormalMapsAndVertexColours) {
  Scene scene = make_cornell_area({.width = 24, .height = 24});
  TriangleMesh out;
  for (uint32_t i = 0; i < scene.mesh.size(); ++i) {
    std::array<glm::vec2, 3> uvs;
    glm::vec4 colours[3];
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 p = scene.mesh.vertex(i, k);
      uvs[static_cast<size_t>(k)] = glm::vec2(p.x + 0.3f * p.z, p.y - 0.2f * p.z);
      colours[k] = glm::vec4(0.6f + 0.4f * glm::abs(glm::sin(2.0f * p)), 1.0f);
    }
    out.add(scene.mesh.vertex(i, 0), scene.mesh.vertex(i, 1), scene.mesh.vertex(i, 2),
            scene.mesh.material()[i], nullptr, &uvs);
    out.set_extras(i, nullptr, colours, nullptr);
  }
  scene.mesh = out;
  TextureImage normals{.width = 2, .height = 2, .rgb = {}, .alpha = {}, .srgb = false};
  normals.rgb = {158, 128, 250, 128, 100, 250, 110, 150, 250, 140, 118, 252};
  scene.textures = {Texture::from_image(normals)};
  for (Material& m : scene.materials) {
    if (!m.emits()) m.normal_texture.index = 0;
  }
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  expect_same_mean(mean_of_renders(scene, accel, BdptIntegrator(scene), 48, 30, 8),
                   mean_of_renders(scene, accel, PathIntegrator(scene), 128, 40, 8), 0.01);
}

// Instanced geometry under the lab's point light (scenes/instances.json).
TEST(Bdpt, AgreesWithThePathTracerOnInstances) {
  const Scene scene = example_scene("instances.json", 32);
  ASSERT_FALSE(scene.instances.empty());
  const auto accel = make_accel(AccelKind::kBvh, scene, Kernel::kWatertight);
  const Image bdpt = render_bdpt(scene, *accel, {}, {.spp = 128, .seed = 1});
  const Image path = render_path(scene, *accel, {.spp = 1024, .seed = 2});
  expect_agree(bdpt, path, 0.01, 16, 0.03, 0.99);
}

// The lab's two blocks alone (no room), white (albedo 1, both sides) under a uniform environment
// of radiance 1: a white furnace, radiance 1 everywhere (escaping camera rays see 1 too). Light
// subpaths start on the disk of the scene's bounding sphere.
TEST(Bdpt, UniformEnvironmentFurnaceGivesOne) {
  const Scene box = make_cornell_box({.width = 16, .height = 16});
  Scene scene = box;
  scene.lights.clear();
  scene.mesh = TriangleMesh();
  for (uint32_t prim = 10; prim < box.mesh.size(); ++prim) {
    const SurfaceTriangle t = stored_triangle(box.mesh, prim);
    scene.mesh.add(t.v0, t.v0 + t.e1, t.v0 + t.e2, 0);
  }
  scene.materials = {Material{.albedo = glm::vec3(1.0f)}};
  scene.environment = glm::vec3(1.0f);
  scene.camera = Camera(16, 16, 0.3, 1.6f);  // close: the blocks fill most of the image
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image image = render_bdpt(scene, accel, {}, {.spp = 64, .seed = 3});
  std::vector<double> v;
  for (const glm::vec3& p : image.pixels()) v.push_back((p.x + p.y + p.z) / 3.0);
  double mean = 0.0, var = 0.0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  for (double x : v) var += (x - mean) * (x - mean);
  const double se = std::sqrt(var / (v.size() - 1.0) / static_cast<double>(v.size()));
  std::printf("  furnace mean %.5f +- %.5f\n", mean, se);
  EXPECT_LT(std::abs(mean - 1.0), 4.0 * se + 1e-4);
  EXPECT_LT(se, 0.01);
}

// Light subpaths from the environment, alone, under a uniform sky: a floor and a square floating
// above it (both white, two-sided), so that every connection between two surfaces is either
// between coplanar points (G = 0) or across the gap (G bounded): the unweighted connection
// strategy has finite variance, which it lacks in a box (1/d^2 at the edges where walls meet).
// Paths of four vertices (camera, two surfaces, the sky) by the camera subpath escaping (0, 4),
// next-event estimation towards the sky (1, 3), and a light subpath from the bounding disk
// connected to the camera's first hit (2, 2).
TEST(Bdpt, UnweightedEnvironmentStrategiesAgree) {
  Scene scene;
  scene.materials = {Material{.albedo = glm::vec3(0.8f), .two_sided = true}};
  const auto square = [&](float y, float half) {
    const glm::vec3 a(-half, y, -half), b(half, y, -half), c(half, y, half), d(-half, y, half);
    scene.mesh.add(a, b, c, 0);
    scene.mesh.add(a, c, d, 0);
  };
  square(1.0f, 2.0f);  // the floor (world y points down)
  square(0.5f, 0.5f);  // the square floating half a unit above it
  scene.environment = glm::vec3(1.0f);
  scene.camera = Camera::look_at(16, 16, {0.0f, -1.0f, -2.5f}, {0.0f, 0.8f, 0.0f},
                                 {0.0f, -1.0f, 0.0f}, Camera::focal_for_vertical_fov(16, 50.0));
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const auto alone = [&](int s, int t, uint32_t spp) {
    const BdptSettings settings{.max_depth = 2, .only_s = s, .only_t = t, .unweighted = true};
    return mean_of_renders(scene, accel, BdptIntegrator(scene, settings), spp, 50, 8);
  };
  const MeanAndError nee = alone(1, 3, 512);
  expect_same_mean(alone(0, 4, 512), nee, 0.03);
  // Few rays from the disk meet the floor and square: a noisy strategy alone, but 10% still tells
  // a wrong density of the disk (pi R^2) or of the direction from the right one.
  expect_same_mean(alone(2, 2, 1024), nee, 0.1);
}

// cornell-area under a uniform sky that enters through the open front, and the sky map scene
// (scenes/sky.json: a sun and sky, gold, rough glass, white): bdpt and path agree.
TEST(Bdpt, AgreesWithThePathTracerUnderEnvironments) {
  Scene open = make_cornell_area({.width = 32, .height = 32});
  open.environment = glm::vec3(0.4f, 0.5f, 0.6f);
  const Scene sky = example_scene("sky.json", 32);
  for (const Scene* scene : {static_cast<const Scene*>(&open), &sky}) {
    const BvhAccel accel(scene->mesh, kDefaultKernel);
    const Image bdpt = render_bdpt(*scene, accel, {}, {.spp = 128, .seed = 1});
    const Image path = render_path(*scene, accel, {.spp = 1024, .seed = 2});
    expect_agree(bdpt, path, 0.01, 16, 0.03, 0.99);
  }
}

// spot_and_sun.json (the lab's box under a spot light and a low sun through its open front) with
// only its spot light, only its sun, or both.
Scene spot_and_sun(int side, bool spot, bool sun) {
  Scene scene = example_scene("spot_and_sun.json", side);
  if (!spot) scene.spot_lights.clear();
  if (!sun) scene.directional_lights.clear();
  return scene;
}

// cornell-area seen through a thin lens focused in front of the short block (blurring the back
// wall and the light), or through an orthographic camera that sees the whole box.
Scene lensed_cornell_area(int side) {
  Scene scene = make_cornell_area({.width = side, .height = side});
  scene.camera = scene.camera.with_lens(0.15f, 2.5f);
  return scene;
}

Scene orthographic_cornell_area(int side) {
  Scene scene = make_cornell_area({.width = side, .height = side});
  scene.camera = scene.camera.orthographic(2.2f / static_cast<float>(side));
  return scene;
}

Scene orthographic_lens_cornell_area(int side) {
  Scene scene = orthographic_cornell_area(side);
  scene.camera = scene.camera.with_lens(0.1f, 3.0f);
  return scene;
}

// The O(1) weight recursion (prepare_weights and mis_weight_recursive in bdpt_integrator.cpp)
// against the ratio walk over the whole path that it replaced (Veach 1997, sec. 10.2), kept in
// the integrator as the oracle: every weight of every connection of small renders, on scenes with
// area and point lights, smooth glass (delta vertices), a smooth coat over diffuse (delta and
// non-delta lobes in one Bsdf), rough glass, an environment map and a uniform sky, spot and
// directional lights together, a thin lens and an orthographic camera, with light tracing on and
// off and both heuristics. The two differ only in rounding.
TEST(Bdpt, WeightRecursionEqualsTheRatioWalk) {
  Scene coated = make_cornell_area({.width = 12, .height = 12});
  for (Material& m : coated.materials) {
    if (m.albedo == glm::vec3(0.15f, 0.15f, 0.75f)) {
      m.type = MaterialType::kPrincipled;
      m.roughness = 0.0f;
    } else if (m.albedo == glm::vec3(0.75f)) {
      m.type = MaterialType::kDielectric;
      m.roughness = 0.3f;
      m.albedo = glm::vec3(0.9f);
    }
  }
  Scene open = make_cornell_area({.width = 12, .height = 12});
  open.environment = glm::vec3(0.4f, 0.5f, 0.6f);
  const std::vector<std::pair<const char*, Scene>> scenes = {
      {"cornell-area", make_cornell_area({.width = 12, .height = 12})},
      {"point light box", make_cornell_box({.width = 12, .height = 12})},
      {"glass.json", example_scene("glass.json", 12)},
      {"coat and rough glass", coated},
      {"open to a uniform sky", open},
      {"sky.json", example_scene("sky.json", 12)},
      {"spot and sun", spot_and_sun(12, true, true)},
      {"thin lens", lensed_cornell_area(12)},
      {"orthographic", orthographic_cornell_area(12)},
      {"orthographic lens", orthographic_lens_cornell_area(12)}};
  for (const auto& [name, scene] : scenes) {
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    for (const bool light_tracing : {true, false}) {
      for (const bool balance : {false, true}) {
        SCOPED_TRACE(std::string(name) + (light_tracing ? ", light tracing" : ", t >= 2") +
                     (balance ? ", balance" : ", power"));
        BdptSettings::WeightCheck check;
        const BdptSettings settings{
            .balance = balance, .light_tracing = light_tracing, .weight_check = &check};
        render_bdpt(scene, accel, settings, {.threads = 1, .spp = 8, .seed = 5});
        std::printf("  %s %d %d: %llu weights, largest difference %.3g\n", name, light_tracing,
                    balance, static_cast<unsigned long long>(check.count), check.max_difference);
        EXPECT_GT(check.count, 1000u);
        EXPECT_LT(check.max_difference, 1e-5) << check.count << " weights";
      }
    }
  }
}

// ---- Spot and directional lights, a thin lens, an orthographic camera ----

// Light subpaths start on the spot light (a delta position, its direction drawn in proportion to
// the cone's falloff) and on the sun (a delta direction, from the disk across the scene's
// bounding sphere); no camera subpath reaches either, so the light subpaths carry all of their
// light.
TEST(Bdpt, AgreesWithThePathTracerUnderASpotLight) {
  const Scene scene = spot_and_sun(32, true, false);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  expect_agree(render_bdpt(scene, accel, {}, {.spp = 128, .seed = 1}),
               render_path(scene, accel, {.spp = 1024, .seed = 2}), 0.005, 16, 0.03, 0.99);
}

TEST(Bdpt, AgreesWithThePathTracerUnderADirectionalLight) {
  const Scene scene = spot_and_sun(32, false, true);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  expect_agree(render_bdpt(scene, accel, {}, {.spp = 128, .seed = 1}),
               render_path(scene, accel, {.spp = 1024, .seed = 2}), 0.005, 16, 0.03, 0.99);
}

TEST(Bdpt, AgreesWithThePathTracerUnderSpotAndDirectionalLightsTogether) {
  const Scene scene = spot_and_sun(32, true, true);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  expect_agree(render_bdpt(scene, accel, {}, {.spp = 128, .seed = 1}),
               render_path(scene, accel, {.spp = 1024, .seed = 2}), 0.005, 16, 0.03, 0.99);
}

// Light tracing connects to a point on the lens and lands where the ray from it crosses the plane
// in focus; the camera's density is the pinhole's from that point. The lab's point-light box
// through a lens by the rule; cornell-area's image mean through a lens varies about 20
// times as much from render to render as through the pinhole (the path tracer's too: its
// blurred ceiling light), so there the means of 8 renders each are compared.
TEST(Bdpt, AgreesWithThePathTracerThroughAThinLens) {
  Scene box = make_cornell_box({.width = 32, .height = 32});
  box.camera = box.camera.with_lens(0.15f, 2.5f);
  const BvhAccel box_accel(box.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(box);
  EXPECT_TRUE(bdpt.splats());
  expect_agree(render(box, box_accel, bdpt, {.spp = 128, .seed = 1}),
               render_path(box, box_accel, {.spp = 1024, .seed = 2}), 0.005, 16, 0.03, 0.99);
  const Scene area = lensed_cornell_area(16);
  const BvhAccel accel(area.mesh, kDefaultKernel);
  expect_same_mean(mean_of_renders(area, accel, BdptIntegrator(area), 64, 50, 8),
                   mean_of_renders(area, accel, PathIntegrator(area), 256, 60, 8), 0.01);
}

// An orthographic camera's direction is a delta: light tracing cannot reach it (the integrator
// turns it off, and with it the splats), and the other strategies carry every path.
TEST(Bdpt, AgreesWithThePathTracerThroughAnOrthographicCamera) {
  const Scene scene = orthographic_cornell_area(32);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene);
  EXPECT_FALSE(bdpt.splats());
  expect_agree(render(scene, accel, bdpt, {.spp = 128, .seed = 1}),
               render_path(scene, accel, {.spp = 1024, .seed = 2}), 0.005, 16, 0.03, 0.99);
}

// With a lens an orthographic camera's rays spread, and light tracing reaches it: each light
// vertex joins the lens point o = its foot on the camera's plane + l z / F (l uniform on the lens,
// z its depth), with the weights' camera density ortho_lens_pdf.
TEST(Bdpt, AgreesWithThePathTracerThroughAnOrthographicCameraWithALens) {
  const Scene scene = orthographic_lens_cornell_area(32);
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene);
  EXPECT_TRUE(bdpt.splats());
  expect_agree(render(scene, accel, bdpt, {.spp = 128, .seed = 1}),
               render_path(scene, accel, {.spp = 1024, .seed = 2}), 0.005, 16, 0.03, 0.99);
}

// The weights of every strategy add up to one on the paths of the new light and camera kinds.
TEST(Bdpt, WeightedStrategiesSumToTheImageWithTheNewLightsAndCameras) {
  for (const Scene& scene : {spot_and_sun(12, true, true), lensed_cornell_area(12),
                             orthographic_cornell_area(12), orthographic_lens_cornell_area(12)}) {
    expect_weighted_strategies_sum_to_the_image(scene);
  }
}

// ---- A light subpath for a share F of the samples (BdptSettings::light_paths) ----

// The O(1) recursion, which carries F in light vertex 1's density and in the connection's
// reverse densities, against the ratio walk, which multiplies each strategy by its own count
// (F for s >= 2, the adaptive ratio for t = 1) explicitly.
TEST(Bdpt, WeightRecursionEqualsTheRatioWalkWithALightPathShare) {
  const std::vector<std::pair<const char*, Scene>> scenes = {
      {"cornell-area", make_cornell_area({.width = 12, .height = 12})},
      {"point light box", make_cornell_box({.width = 12, .height = 12})},
      {"glass.json", example_scene("glass.json", 12)},
      {"sky.json", example_scene("sky.json", 12)},
      {"spot and sun", spot_and_sun(12, true, true)},
      {"orthographic lens", orthographic_lens_cornell_area(12)}};
  for (const auto& [name, scene] : scenes) {
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    for (const float light_paths : {0.25f, 0.5f}) {
      for (const bool light_tracing : {true, false}) {
        const bool balance = !light_tracing;
        SCOPED_TRACE(std::string(name) + " F " + std::to_string(light_paths) +
                     (light_tracing ? ", light tracing" : ", t >= 2") +
                     (balance ? ", balance" : ", power"));
        BdptSettings::WeightCheck check;
        const BdptSettings settings{.balance = balance,
                                    .light_tracing = light_tracing,
                                    .weight_check = &check,
                                    .light_paths = light_paths};
        render_bdpt(scene, accel, settings, {.threads = 1, .spp = 8, .seed = 5});
        std::printf("  %s F %g %d: %llu weights, largest difference %.3g\n", name, light_paths,
                    light_tracing, static_cast<unsigned long long>(check.count),
                    check.max_difference);
        EXPECT_GT(check.count, 500u);
        EXPECT_LT(check.max_difference, 1e-5) << check.count << " weights";
      }
    }
  }
}

TEST(Bdpt, WeightedStrategiesSumToTheImageWithALightPathShare) {
  expect_weighted_strategies_sum_to_the_image(make_cornell_area({.width = 12, .height = 12}),
                                              0.25f);
}

// Weights that sum to one over the strategies, with each strategy's contributions divided by its
// share of the samples, leave the image unbiased: bdpt with a light subpath in a quarter of the
// samples against the path tracer, under the area light and through glass (the tolerances of the
// tests above), and under the lab's point light (which only light subpaths find: s = 1 and
// s >= 2).
void expect_agree_with_a_light_path_share(const Scene& scene, double tolerance) {
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const Image bdpt = render_bdpt(scene, accel, {.light_paths = 0.25f}, {.spp = 256, .seed = 1});
  const Image path = render_path(scene, accel, {.spp = 1024, .seed = 2});
  expect_agree(bdpt, path, tolerance, 16, 0.03, 0.99);
}

TEST(Bdpt, AgreesWithThePathTracerWithALightPathShare) {
  {
    SCOPED_TRACE("cornell-area");
    expect_agree_with_a_light_path_share(make_cornell_area({.width = 32, .height = 32}), 0.005);
  }
  SCOPED_TRACE("glass.json");
  expect_agree_with_a_light_path_share(example_scene("glass.json", 32), 0.01);
}

TEST(Bdpt, AgreesWithThePathTracerUnderThePointLightWithALightPathShare) {
  expect_agree_with_a_light_path_share(make_cornell_box({.width = 32, .height = 32}), 0.005);
}

// The share's division alone (no weights): a strategy that needs the light subpath past its first
// vertex, unweighted, against one that does not. F = 0.3 with 32 samples per pixel is 9.6 light
// subpaths a pixel, not a whole number: the per-pixel phase keeps each sample's chance exactly F.
// (2, 2) and (1, 3) sample the paths of one bounce between camera and light; (2, 1) (light
// tracing) and (1, 2) direct light. 32 renders each: (2, 2)'s variance is unbounded (above).
TEST(Bdpt, UnweightedStrategiesWithALightPathShareAgree) {
  const Scene scene = make_cornell_area({.width = 16, .height = 16});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const auto alone = [&](int s, int t, int max_depth, float light_paths, uint32_t spp) {
    const BdptSettings settings{.max_depth = max_depth,
                                .only_s = s,
                                .only_t = t,
                                .unweighted = true,
                                .light_paths = light_paths};
    return mean_of_renders(scene, accel, BdptIntegrator(scene, settings), spp, 10, 32);
  };
  std::printf("  (2, 2) at F 0.3 vs (1, 3):\n");
  expect_same_mean(alone(2, 2, 2, 0.3f, 256), alone(1, 3, 2, 1.0f, 32), 0.02);
  std::printf("  (2, 1) at F 0.3 vs (1, 2):\n");
  expect_same_mean(alone(2, 1, 1, 0.3f, 64), alone(1, 2, 1, 1.0f, 16), 0.02);
}

// Which samples trace a light subpath is a function of (seed, pixel, sample index): the same bits
// for any thread count and tile size, and the light image of samples [0, 7) and [7, 19) rendered
// apart into one film is the one render's.
TEST(Bdpt, LightPathShareIsTheSameForThreadsTilesAndSampleRanges) {
  const Scene scene = make_cornell_box({.width = 24, .height = 20});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene, {.light_paths = 0.3f});
  const Image want = render(scene, accel, bdpt, {.threads = 1, .tile_size = 16, .spp = 19});
  for (int threads : {2, 3}) {
    for (int tile : {1, 5}) {
      EXPECT_TRUE(same_bits(
          want, render(scene, accel, bdpt, {.threads = threads, .tile_size = tile, .spp = 19})))
          << threads << " threads, tile " << tile;
    }
  }
  Film parts(24, 20);
  render_to_film(scene, accel, bdpt, parts, {.threads = 2, .spp = 7});
  render_to_film(scene, accel, bdpt, parts, {.threads = 3, .spp = 12, .first_sample = 7});
  EXPECT_TRUE(same_bits(want, parts.resolve()));
  // The share changes the image (a vacuous setting would not).
  EXPECT_FALSE(same_bits(want, render(scene, accel, BdptIntegrator(scene), {.spp = 19})));
}

TEST(Bdpt, RefusesALightPathShareOutsideZeroToOne) {
  const Scene scene = make_cornell_area({.width = 8, .height = 8});
  for (const float bad : {0.0f, -0.5f, 1.5f, 1e-9f, std::nanf("")}) {
    EXPECT_THROW(BdptIntegrator(scene, {.light_paths = bad}), Error) << bad;
  }
  EXPECT_NO_THROW(BdptIntegrator(scene, {.light_paths = 1e-6f}));
  EXPECT_NO_THROW(BdptIntegrator(scene, {.light_paths = 1.0f}));
}

}  // namespace
}  // namespace tritrace
