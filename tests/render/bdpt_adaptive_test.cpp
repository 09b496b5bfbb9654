// bdpt with adaptive sampling (--noise-threshold) against oracles that do not use it: the image
// mean over seeds agrees with uniform bdpt's and the path tracer's (unbiased), the image is the
// same bits for 1 and 7 threads, any tile size and any split into passes (the --time-limit way),
// the spp AOV shows pixels that stopped after the pilot beside pixels that went on, and the MIS
// weights with light tracing's count ratio other than 1 agree with the ratio walk over the whole
// path (which applies the ratio as a factor of light tracing's strategies) and stay a partition
// of unity (the image mean does not move when only the weights' ratio changes).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <string>
#include <vector>

#include "example_scene.h"
#include "mean_and_error.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

using testing_scenes::example_scene;

using testing_mc::expect_same_mean;
using testing_mc::mean_of;

using testing_mc::luminance_mean;
using testing_mc::same_bits;

// Renders into `film` in passes of the given sample counts, continuing one adaptive state (as
// --time-limit renders), each pass on `threads` threads.
void render_in_passes(const Scene& scene, const Accel& accel, const Integrator& bdpt, Film& film,
                      const RenderOptions& base, unsigned threads,
                      std::initializer_list<uint32_t> counts) {
  AdaptiveState state;
  uint32_t taken = 0;
  for (uint32_t n : counts) {
    RenderOptions pass = base;
    pass.threads = threads;
    pass.first_sample = taken;
    pass.spp = n;
    pass.adaptive_state = &state;
    render_to_film(scene, accel, bdpt, film, pass);
    taken += n;
  }
}

// The same samples give the same bits: 1 and 7 threads, tile sizes 16 and 5 (adaptive sampling
// renders 16 x 16 tiles whatever it says), render() and a film, and a film continued in passes of
// 8, 24, 40 and 56 samples with the adaptive state (as --time-limit renders). The spp AOV shows
// where samples went: pixels that stopped after the pilot's 64 and pixels that took 128 or more.
TEST(BdptAdaptive, SameBitsForOneAndSevenThreadsTilesAndPassesAndTheSppAovShowsTheBudgets) {
  const Scene scene = make_cornell_area({.width = 24, .height = 20});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene);
  const RenderOptions base{.threads = 1, .spp = 128, .seed = 3, .noise_threshold = 0.1f};
  const Image want = render(scene, accel, bdpt, base);
  RenderOptions seven = base;
  seven.threads = 7;
  seven.tile_size = 5;
  EXPECT_TRUE(same_bits(want, render(scene, accel, bdpt, seven)));
  Film one(24, 20, AovSet{.spp = true});
  render_to_film(scene, accel, bdpt, one, seven);
  EXPECT_TRUE(same_bits(want, one.resolve()));
  Film passes(24, 20, AovSet{.spp = true});
  render_in_passes(scene, accel, bdpt, passes, base, 3, {8u, 24u, 40u, 56u});
  EXPECT_TRUE(same_bits(want, passes.resolve()));
  const Image spp = one.resolve_spp();
  EXPECT_TRUE(same_bits(spp, passes.resolve_spp()));
  float least = 1e9f, most = 0.0f;
  for (const glm::vec3& p : spp.pixels()) {
    least = std::min(least, p.x);
    most = std::max(most, p.x);
  }
  EXPECT_EQ(least, 64.0f);
  EXPECT_EQ(most, 128.0f);
  // Adaptive sampling changed the image (its pilot's splats and its counts), so the comparisons
  // above are not of uniform renders.
  EXPECT_FALSE(same_bits(want, render(scene, accel, bdpt, {.threads = 1, .spp = 128, .seed = 3})));
}

// Unbiased: the image mean over seeds, adaptive (budgets from 64 to 256 samples), agrees within 4
// standard errors with uniform bdpt's and with the path tracer's, on cornell-area and on the
// glass sphere in the box (caustics through light tracing's strategies).
TEST(BdptAdaptive, ImageMeanOverSeedsAgreesWithUniformBdptAndThePathTracer) {
  const std::vector<std::pair<const char*, Scene>> scenes = {
      {"cornell-area", make_cornell_area({.width = 16, .height = 16})},
      {"glass.json", example_scene("glass.json", 16)}};
  // (Named references, not a structured binding: clang 14, CI's sanitizer compiler, cannot
  // capture a binding in the lambdas below.)
  for (const auto& entry : scenes) {
    const Scene& scene = entry.second;
    SCOPED_TRACE(entry.first);
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    const BdptIntegrator bdpt(scene);
    const PathIntegrator path(scene);
    constexpr int kSeeds = 10;
    double samples = 0.0;
    const auto adaptive = mean_of(kSeeds, [&](int k) {
      RenderStats stats;
      const Image im =
          render(scene, accel, bdpt,
                 {.spp = 256, .seed = uint64_t(100 + k), .noise_threshold = 0.1f}, &stats);
      samples += stats.mean_spp();
      return luminance_mean(im);
    });
    const auto uniform = mean_of(kSeeds, [&](int k) {
      return luminance_mean(render(scene, accel, bdpt, {.spp = 128, .seed = uint64_t(200 + k)}));
    });
    const auto reference = mean_of(kSeeds, [&](int k) {
      return luminance_mean(render(scene, accel, path, {.spp = 256, .seed = uint64_t(300 + k)}));
    });
    samples /= kSeeds;
    std::printf("  %s: adaptive took %.1f spp on average\n", entry.first, samples);
    expect_same_mean(adaptive, uniform, 0.02);
    expect_same_mean(adaptive, reference, 0.02);
    // Budgets differed: some pixels stopped before 256.
    EXPECT_LT(samples, 250.0);
    EXPECT_GT(samples, 64.0);
  }
}

// The count ratio in the weights: the O(1) recursion (the ratio in the camera's density at camera
// vertex 1 and in light tracing's density of its light vertex) against the walk over the whole
// path (the ratio as a factor of light tracing's strategies), with ratios far from 1 (the tests'
// scale on the weights alone) and with adaptive sampling's own (the pilot's (P - neighbours) / P,
// then the share of pixels taking each pass), on scenes with delta vertices and a point light,
// through a thin lens and an orthographic camera with a lens.
TEST(BdptAdaptive, WeightRecursionEqualsTheRatioWalkWithCountRatios) {
  Scene lens = make_cornell_area({.width = 12, .height = 12});
  lens.camera = lens.camera.with_lens(0.15f, 2.5f);
  Scene ortho_lens = make_cornell_area({.width = 12, .height = 12});
  ortho_lens.camera = ortho_lens.camera.orthographic(2.2f / 12.0f).with_lens(0.1f, 3.0f);
  const std::vector<std::pair<const char*, Scene>> scenes = {
      {"cornell-area", make_cornell_area({.width = 12, .height = 12})},
      {"point light box", make_cornell_box({.width = 12, .height = 12})},
      {"glass.json", example_scene("glass.json", 12)},
      {"thin lens", lens},
      {"orthographic with a lens", ortho_lens}};
  for (const auto& [name, scene] : scenes) {
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    for (const float scale : {0.05f, 1.0f, 20.0f}) {
      for (const bool balance : {false, true}) {
        SCOPED_TRACE(std::string(name) + " scale " + std::to_string(scale) +
                     (balance ? ", balance" : ", power"));
        BdptSettings::WeightCheck check;
        const BdptIntegrator bdpt(
            scene, {.balance = balance, .weight_check = &check, .mis_count_scale = scale});
        (void)render(scene, accel, bdpt,
                     {.threads = 1, .spp = 72, .seed = 5, .noise_threshold = 0.3f});
        std::printf("  %s scale %g %d: %llu weights, largest difference %.3g\n", name, scale,
                    balance, static_cast<unsigned long long>(check.count), check.max_difference);
        EXPECT_GT(check.count, 1000u);
        EXPECT_LT(check.max_difference, 1e-5) << check.count << " weights";
      }
    }
  }
}

// Weights that sum to one over the strategies for any count ratio leave the estimate unbiased:
// with the ratio in the weights scaled by 1/8 or 8 (the splats' normalisation unchanged), the
// image mean does not move. Paired by seed against the weights with ratio 1 (the same samples,
// only the weights differ), the mean difference is within 4 standard errors of 0, and those
// errors are below 0.3% of the image mean. Weights that did not sum to one would move it by the
// share of the light that light tracing's strategies carry.
TEST(BdptAdaptive, WeightsStayAPartitionOfUnityForCountRatiosOtherThanOne) {
  for (const bool glass : {false, true}) {
    const Scene scene =
        glass ? example_scene("glass.json", 16) : make_cornell_area({.width = 16, .height = 16});
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    const BdptIntegrator plain(scene);
    std::vector<double> plain_means;
    for (int k = 0; k < 8; ++k) {
      plain_means.push_back(
          luminance_mean(render(scene, accel, plain, {.spp = 64, .seed = uint64_t(40 + k)})));
    }
    for (const float scale : {0.125f, 8.0f}) {
      SCOPED_TRACE(std::string(glass ? "glass.json" : "cornell-area") + " scale " +
                   std::to_string(scale));
      const BdptIntegrator bdpt(scene, {.mis_count_scale = scale});
      const auto difference = mean_of(8, [&](int k) {
        return luminance_mean(render(scene, accel, bdpt, {.spp = 64, .seed = uint64_t(40 + k)})) -
               plain_means[static_cast<size_t>(k)];
      });
      std::printf("  %s scale %g: mean difference %.6f +- %.6f of %.6f\n",
                  glass ? "glass.json" : "cornell-area", scale, difference.mean, difference.error,
                  plain_means[0]);
      EXPECT_LT(std::abs(difference.mean), 4.0 * difference.error);
      EXPECT_GT(difference.error, 0.0);
      EXPECT_LT(difference.error, 0.003 * plain_means[0]);
    }
  }
}

// A light subpath in a share of the samples (BdptSettings::light_paths) on top of adaptive
// sampling: light tracing's strategies then count the pass's ratio times the share. The recursion
// against the walk (which applies both counts as factors of whole strategies), and the same bits
// for one and three threads and in passes.
TEST(BdptAdaptive, LightPathShareWeightsAndBitsWithCountRatios) {
  for (const bool glass : {false, true}) {
    const Scene scene =
        glass ? example_scene("glass.json", 12) : make_cornell_area({.width = 12, .height = 12});
    const BvhAccel accel(scene.mesh, kDefaultKernel);
    for (const float scale : {0.05f, 20.0f}) {
      SCOPED_TRACE(std::string(glass ? "glass.json" : "cornell-area") + " scale " +
                   std::to_string(scale));
      BdptSettings::WeightCheck check;
      const BdptIntegrator bdpt(
          scene, {.weight_check = &check, .mis_count_scale = scale, .light_paths = 0.25f});
      (void)render(scene, accel, bdpt,
                   {.threads = 1, .spp = 72, .seed = 5, .noise_threshold = 0.3f});
      std::printf("  %s scale %g F 0.25: %llu weights, largest difference %.3g\n",
                  glass ? "glass.json" : "cornell-area", scale,
                  static_cast<unsigned long long>(check.count), check.max_difference);
      EXPECT_GT(check.count, 1000u);
      EXPECT_LT(check.max_difference, 1e-5) << check.count << " weights";
    }
  }
  const Scene scene = make_cornell_area({.width = 20, .height = 18});
  const BvhAccel accel(scene.mesh, kDefaultKernel);
  const BdptIntegrator bdpt(scene, {.light_paths = 0.3f});
  const RenderOptions base{.threads = 1, .spp = 128, .seed = 3, .noise_threshold = 0.1f};
  const Image want = render(scene, accel, bdpt, base);
  RenderOptions three = base;
  three.threads = 3;
  three.tile_size = 5;
  EXPECT_TRUE(same_bits(want, render(scene, accel, bdpt, three)));
  Film passes(20, 18);
  render_in_passes(scene, accel, bdpt, passes, base, 2, {40u, 88u});
  EXPECT_TRUE(same_bits(want, passes.resolve()));
}

}  // namespace
}  // namespace tritrace
