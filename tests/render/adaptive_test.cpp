// Adaptive sampling (--noise-threshold): each pixel's budget from its neighbours' pilot samples
// within its 16 x 16 tile, so the film is the same for any thread count and tile size; each pixel
// is exactly the uniform render of the samples it took (the block tree adds zeros for the samples
// it did not take); pixels among flat neighbours stop after the pilot (64) and those among noisy
// ones go on; the image mean stays that of uniform sampling, also for rare bright samples.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/error.h"
#include "tritrace/render/integrator.h"
#include "tritrace/render/path_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/cornell_box.h"

namespace tritrace {
namespace {

const AovSet kSppAndVariance{.variance = true, .spp = true};

class AdaptiveTest : public ::testing::Test {
 protected:
  AdaptiveTest()
      : scene_(make_cornell_area({.width = 40, .height = 24})),
        accel_(make_accel(AccelKind::kBvh, scene_, kDefaultKernel)),
        integrator_(scene_) {}

  Film film(RenderOptions options, AovSet aovs = kSppAndVariance,
            RenderStats* stats = nullptr) const {
    Film f(scene_.camera.width(), scene_.camera.height(), aovs);
    render_to_film(scene_, *accel_, integrator_, f, options, stats);
    return f;
  }

  Scene scene_;
  std::unique_ptr<Accel> accel_;
  PathIntegrator integrator_;
};

bool same_bits(const Image& a, const Image& b) {
  return a.width() == b.width() && a.height() == b.height() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)) ==
             0;
}

TEST_F(AdaptiveTest, SameBitsForAnyThreadCountAndTileSize) {
  const RenderOptions one{.threads = 1, .spp = 128, .noise_threshold = 0.05f};
  const Film a = film(one);
  RenderOptions seven = one;
  seven.threads = 7;
  seven.tile_size = 5;
  const Film b = film(seven);
  EXPECT_TRUE(same_bits(a.resolve(), b.resolve()));
  EXPECT_TRUE(same_bits(a.resolve_spp(), b.resolve_spp()));
  EXPECT_TRUE(same_bits(a.resolve_variance(), b.resolve_variance()));
  // The film-less render gives the film's image bit for bit.
  EXPECT_TRUE(same_bits(a.resolve(), render(scene_, *accel_, integrator_, seven)));
  // The threshold stopped some pixels, or the test would show nothing.
  const Image spp = a.resolve_spp();
  size_t early = 0;
  for (const glm::vec3& p : spp.pixels()) early += p.x < 128.0f;
  EXPECT_GT(early, 0u);
  EXPECT_LT(early, spp.pixels().size());
}

// The samples a pixel did not take add zeros at the end of the block tree, so a pixel that
// stopped at n samples is, bit for bit, that pixel of the uniform render of n spp: an oracle that
// shares nothing with the stopping rule.
TEST_F(AdaptiveTest, EachPixelIsTheUniformRenderOfTheSamplesItTook) {
  const uint32_t spp = 128;
  RenderStats stats;
  const Film adaptive =
      film({.threads = 2, .spp = spp, .noise_threshold = 0.05f}, kSppAndVariance, &stats);
  const Image image = adaptive.resolve();
  const Image taken = adaptive.resolve_spp();
  std::vector<std::pair<uint32_t, Image>> uniform;
  for (uint32_t n : {32u, 64u, 128u}) {
    uniform.emplace_back(n, render(scene_, *accel_, integrator_, {.threads = 2, .spp = n}));
  }
  double total = 0.0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const float n = taken.at(x, y).x;
      total += n;
      const Image* want = nullptr;
      for (const auto& [count, im] : uniform) {
        if (static_cast<float>(count) == n) want = &im;
      }
      ASSERT_NE(want, nullptr) << "pixel " << x << "," << y << " took " << n << " samples";
      EXPECT_EQ(image.at(x, y), want->at(x, y)) << x << "," << y << " at " << n << " spp";
    }
  }
  // The statistics count the samples taken, as the AOV does.
  EXPECT_EQ(static_cast<double>(stats.samples), total);
  EXPECT_EQ(stats.pixels, 40u * 24u);
  EXPECT_EQ(stats.spp, spp);
}

// A pixel's budget follows its neighbours (the 5 x 5 around it within its 16 x 16 tile, itself
// left out): a pixel whose neighbours all see the light's constant emission (zero variance) stops
// after the pilot, at 64; one whose neighbours' half buffers (an estimate the rule does not use)
// show a relative error far above the threshold at 32 spp goes on past 64.
TEST(AdaptiveSampling, PixelsAmongFlatNeighboursStopAfterThePilotAmongNoisyOnesGoOn) {
  // Large enough that the light covers whole 5 x 5 neighbourhoods.
  constexpr int kSize = 192;
  const Scene scene = make_cornell_area({.width = kSize, .height = kSize});
  const auto accel = make_accel(AccelKind::kBvh, scene, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const auto film = [&](RenderOptions options, AovSet aovs) {
    Film f(kSize, kSize, aovs);
    render_to_film(scene, *accel, integrator, f, options);
    return f;
  };
  const float threshold = 0.02f;
  const Film first = film({.threads = 2, .spp = 32}, {.variance = true});
  const Image mean = first.resolve(), variance = first.resolve_variance();
  const Image taken =
      film({.threads = 2, .spp = 128, .noise_threshold = threshold}, {.spp = true}).resolve_spp();
  const auto flat_at = [&](int x, int y) {
    // Every sample saw the light (a pixel that is part light, part its unlit back, can have
    // equal halves and a smaller mean).
    return mean.at(x, y) == kAreaLightRadiance && variance.at(x, y) == glm::vec3(0.0f);
  };
  // A pixel's squared error at 32 spp from its half buffers: the variance of its mean over its
  // luminance (at least kAdaptiveDarkFloor).
  const auto squared_error_at = [&](int x, int y) {
    const glm::vec3 m = mean.at(x, y), v = variance.at(x, y);
    const float luminance = 0.2126f * m.x + 0.7152f * m.y + 0.0722f * m.z;
    const float var = 0.2126f * v.x + 0.7152f * v.y + 0.0722f * v.z;
    return var / std::max(luminance, float(kAdaptiveDarkFloor));
  };
  // Calls fn for every neighbour of (x, y) within its tile.
  const auto for_around = [&](int x, int y, auto&& fn) {
    for (int dy = -kAdaptiveRadius; dy <= kAdaptiveRadius; ++dy) {
      for (int dx = -kAdaptiveRadius; dx <= kAdaptiveRadius; ++dx) {
        const int nx = x + dx, ny = y + dy;
        if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= kSize || ny >= kSize ||
            nx / kPartTileSize != x / kPartTileSize || ny / kPartTileSize != y / kPartTileSize) {
          continue;
        }
        fn(nx, ny);
      }
    }
  };
  const auto all_around = [&](int x, int y, auto&& pred) {
    bool all = true;
    for_around(x, y, [&](int nx, int ny) { all = all && pred(nx, ny); });
    return all;
  };
  // The neighbours' errors at 32 spp, root mean square, far above T (at 64 they should be about
  // 1 / sqrt(2) of it, still above T).
  const auto noisy_around = [&](int x, int y) {
    double sum = 0.0;
    int n = 0;
    for_around(x, y, [&](int nx, int ny) {
      sum += squared_error_at(nx, ny);
      ++n;
    });
    return std::sqrt(sum / n) > 4.0 * threshold;
  };
  size_t flat = 0, noisy = 0, noisy_on = 0;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      const float n = taken.at(x, y).x;
      if (all_around(x, y, flat_at)) {
        ++flat;
        EXPECT_EQ(n, 64.0f) << x << "," << y;
      }
      if (noisy_around(x, y)) {
        ++noisy;
        noisy_on += n > 64.0f;
      }
    }
  }
  EXPECT_GT(flat, 10u);
  EXPECT_GT(noisy, 10u);
  EXPECT_GE(static_cast<double>(noisy_on), 0.95 * static_cast<double>(noisy));
}

// The neighbourhood's error is the root mean square of the neighbours' errors after the pilot,
// and the budget the pilot times e / T, rounded up to the pilot times a power of two.
TEST(AdaptiveError, NeighbourhoodErrorAndBudget) {
  PixelMoments flat, noisy;
  for (uint32_t i = 0; i < kAdaptivePilotSpp; ++i) {
    flat.add(1.0, 2.0);
    noisy.add(1.0, i % 2 == 0 ? 0.0 : 2.0);  // mean 1, sample variance 64/63
  }
  const double e_noisy = std::sqrt(64.0 / 63.0 / 64.0);  // over sqrt(1)
  EXPECT_NEAR(adaptive_error(noisy, kAdaptivePilotSpp), e_noisy, 1e-12);
  const PixelMoments* both[] = {&flat, &noisy};
  EXPECT_NEAR(neighbourhood_error(both), std::sqrt(e_noisy * e_noisy / 2.0), 1e-12);
  EXPECT_TRUE(std::isinf(neighbourhood_error({})));
  EXPECT_EQ(adaptive_budget(0.0, 0.05), kAdaptivePilotSpp);
  EXPECT_EQ(adaptive_budget(0.049, 0.05), 64u);
  EXPECT_EQ(adaptive_budget(0.05, 0.05), 128u);  // e / T = 1 is not below 1
  // 0.2 / 0.05 = 4 times the pilot, 256, with e / T x 64 / n = 1 not below 1: 512; just below
  // 0.2, 256; 0.7 asks for 896, so 1024.
  EXPECT_EQ(adaptive_budget(0.1999, 0.05), 256u);
  EXPECT_EQ(adaptive_budget(0.2, 0.05), 512u);
  EXPECT_EQ(adaptive_budget(0.7, 0.05), 1024u);
  EXPECT_EQ(adaptive_budget(std::numeric_limits<double>::infinity(), 0.05), kAdaptiveMostBudget);
}

// The image mean over several seeds agrees with uniform sampling's (other seeds, so independent)
// within 4 standard errors, while adaptive sampling takes far fewer samples.
TEST(AdaptiveUnbiased, ImageMeanOverSeedsAgreesWithUniformSampling) {
  const Scene scene = make_cornell_area({.width = 32, .height = 32});
  const auto accel = make_accel(AccelKind::kBvh, scene, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const auto image_mean = [](const Image& im) {
    double sum = 0.0;
    for (const glm::vec3& p : im.pixels()) sum += (p.x + p.y + p.z) / 3.0;
    return sum / static_cast<double>(im.pixels().size());
  };
  constexpr int kSeeds = 8;
  std::vector<double> adaptive, uniform;
  double samples = 0.0;
  for (int s = 0; s < kSeeds; ++s) {
    RenderStats stats;
    adaptive.push_back(image_mean(
        render(scene, *accel, integrator,
               {.threads = 2, .spp = 128, .seed = uint64_t(s), .noise_threshold = 0.1f}, &stats)));
    samples += stats.mean_spp();
    uniform.push_back(image_mean(
        render(scene, *accel, integrator, {.threads = 2, .spp = 128, .seed = uint64_t(100 + s)})));
  }
  const auto mean_and_var = [](const std::vector<double>& v) {
    double m = 0.0, q = 0.0;
    for (double x : v) m += x;
    m /= static_cast<double>(v.size());
    for (double x : v) q += (x - m) * (x - m);
    return std::pair{m, q / static_cast<double>(v.size() - 1)};
  };
  const auto [ma, va] = mean_and_var(adaptive);
  const auto [mu, vu] = mean_and_var(uniform);
  const double se = std::sqrt(va / kSeeds + vu / kSeeds);
  EXPECT_GT(se, 0.0);
  EXPECT_LT(std::abs(ma - mu), 4.0 * se) << ma << " vs " << mu << ", se " << se;
  EXPECT_LT(samples / kSeeds, 100.0) << "adaptive sampling should have stopped pixels early";
}

// A synthetic integrand with a rare large value, the shape of a caustic seen through glass:
// radiance kFlash with probability kChance (one uniform number per sample), else 0. Its mean
// kChance x kFlash = 1 is known exactly, independent of the renderer.
class RareFlash final : public Integrator {
 public:
  static constexpr float kChance = 1.0f / 1024.0f;
  static constexpr float kFlash = 1024.0f;
  uint64_t radiance(const SampleBatch& batch, const SampleOutput& out, const Scene&,
                    const Accel&) const override {
    for (size_t i = 0; i < batch.rays.size(); ++i) {
      out.radiance[i] = glm::vec3(batch.samplers[i].get_1d() < kChance ? kFlash : 0.0f);
    }
    return 0;
  }
};

// A rule that stops a pixel on its own samples is biased here: a pixel whose samples have not
// met the flash has zero sample variance and stops with 0, one that has met it goes on and
// dilutes it. The rule before this one (stop at 64 when the error is below T there and at 32)
// stops with probability q = (1 - 1/1024)^64 = 0.94 and so has mean 1 - 0.75 q = 0.30 at 256 spp
// (it failed this test by far). The image mean must be 1 within 4 standard errors (from the spread
// of the per-seed image means). The independent sampler makes the flashes independent; the Sobol
// sampler stratifies this one dimension so well that every pixel meets the flash once per 1024
// samples and nothing would stop.
TEST(AdaptiveUnbiased, RareBrightSamplesKeepTheImageMean) {
  const Scene scene = make_cornell_area({.width = 32, .height = 32});
  const auto accel = make_accel(AccelKind::kBrute, scene, kDefaultKernel);
  const RareFlash integrator;
  constexpr int kSeeds = 8;
  std::vector<double> means;
  double samples = 0.0;
  for (int s = 0; s < kSeeds; ++s) {
    RenderStats stats;
    const Image im = render(scene, *accel, integrator,
                            {.threads = 2,
                             .spp = 256,
                             .seed = uint64_t(s),
                             .sampler = SamplerKind::kIndependent,
                             .noise_threshold = 0.05f},
                            &stats);
    double sum = 0.0;
    for (const glm::vec3& p : im.pixels()) sum += p.x;
    means.push_back(sum / static_cast<double>(im.pixels().size()));
    samples += stats.mean_spp();
  }
  double m = 0.0, q = 0.0;
  for (double x : means) m += x;
  m /= kSeeds;
  for (double x : means) q += (x - m) * (x - m);
  const double se = std::sqrt(q / (kSeeds - 1) / kSeeds);
  const double expected = double{RareFlash::kChance} * RareFlash::kFlash;
  EXPECT_GT(se, 0.0);
  EXPECT_LT(std::abs(m - expected), 4.0 * se) << m << " vs " << expected << ", se " << se;
  // Pixels whose neighbours met no flash stopped early, or the test would show nothing.
  EXPECT_LT(samples / kSeeds, 200.0);
}

TEST_F(AdaptiveTest, NeedsTheSamplesFromZeroInOneGo) {
  const RenderOptions later{.threads = 1, .spp = 8, .first_sample = 8, .noise_threshold = 0.1f};
  EXPECT_THROW(film(later), Error);
  EXPECT_THROW(render(scene_, *accel_, integrator_, later), Error);
  Film f(scene_.camera.width(), scene_.camera.height());
  render_to_film(scene_, *accel_, integrator_, f, {.threads = 1, .spp = 8});
  EXPECT_THROW(render_to_film(scene_, *accel_, integrator_, f,
                              {.threads = 1, .spp = 8, .first_sample = 8, .noise_threshold = 0.1f}),
               Error);
}

// Passes that continue one film with the adaptive state (how --time-limit renders with
// --noise-threshold) make every decision one call of the same total spp makes: the film, its
// variance and spp AOVs are the one-call film's bit for bit, whether a pass ends before, at or
// after a check (32, 64, 128), and whatever the threads and tile size of each pass.
TEST_F(AdaptiveTest, PassesWithTheStateAreOneCallBitForBit) {
  const RenderOptions whole{.threads = 1, .spp = 200, .noise_threshold = 0.05f};
  const Film one = film(whole);
  Film passes(scene_.camera.width(), scene_.camera.height(), kSppAndVariance);
  AdaptiveState state;
  const uint32_t cuts[] = {0, 8, 32, 40, 64, 128, 136, 200};
  for (size_t k = 0; k + 1 < std::size(cuts); ++k) {
    RenderOptions pass = whole;
    pass.threads = 1 + static_cast<int>(k % 3);
    pass.tile_size = 3 + static_cast<int>(k);
    pass.first_sample = cuts[k];
    pass.spp = cuts[k + 1] - cuts[k];
    pass.adaptive_state = &state;
    render_to_film(scene_, *accel_, integrator_, passes, pass);
    EXPECT_EQ(state.end_sample, cuts[k + 1]);
  }
  EXPECT_TRUE(same_bits(one.resolve(), passes.resolve()));
  EXPECT_TRUE(same_bits(one.resolve_spp(), passes.resolve_spp()));
  EXPECT_TRUE(same_bits(one.resolve_variance(), passes.resolve_variance()));
  // Pixels stopped early (or the test would show nothing), and the state counts those still on:
  // the pixels whose spp AOV is the most.
  const Image spp = one.resolve_spp();
  const size_t on = static_cast<size_t>(std::count_if(
      spp.pixels().begin(), spp.pixels().end(), [](const glm::vec3& p) { return p.x == 200.0f; }));
  EXPECT_LT(on, spp.pixels().size());
  // A pixel still on at 200 has a budget above 200; the state says active for it and for no
  // other pixel.
  EXPECT_EQ(state.active_pixels(), on);
  // A pass that does not continue the state's end is refused.
  RenderOptions wrong = whole;
  wrong.first_sample = 200;
  wrong.spp = 8;
  AdaptiveState other;
  wrong.adaptive_state = &other;
  EXPECT_THROW(render_to_film(scene_, *accel_, integrator_, passes, wrong), Error);
}

TEST(AdaptiveError, StandardErrorOverTheSquareRootOfTheMeanWithADarkFloor) {
  PixelMoments m;
  // Samples 1 and 3, unit weights: mean 2, sample variance 2, variance of the mean 1.
  m.add(1.0, 1.0);
  m.add(1.0, 3.0);
  EXPECT_NEAR(adaptive_error(m, 2), 1.0 / std::sqrt(2.0), 1e-12);
  // Samples 4 and 12: mean 8, standard error 4; relative to sqrt(8), not to 8.
  PixelMoments bright;
  bright.add(1.0, 4.0);
  bright.add(1.0, 12.0);
  EXPECT_NEAR(adaptive_error(bright, 2), 4.0 / std::sqrt(8.0), 1e-12);
  // Weights: samples 2 (weight 1) and 6 (weight 3) make x_i = 2, 18, mean 20 / 4 = 5; the ratio
  // estimator's variance ((2 - 5)^2 + (18 - 15)^2) / 4^2 x 2 / 1 = 2.25.
  PixelMoments weighted;
  weighted.add(1.0, 2.0);
  weighted.add(3.0, 6.0);
  EXPECT_NEAR(adaptive_error(weighted, 2), 1.5 / std::sqrt(5.0), 1e-12);
  // Constant samples: no error.
  PixelMoments flat;
  for (int i = 0; i < 4; ++i) flat.add(1.0, 0.7);
  EXPECT_NEAR(adaptive_error(flat, 4), 0.0, 1e-9);
  // A dark pixel's error is relative to the floor's root: samples 0 and 0.002, standard error
  // 0.001.
  PixelMoments dark;
  dark.add(1.0, 0.0);
  dark.add(1.0, 0.002);
  EXPECT_NEAR(adaptive_error(dark, 2), 0.001 / std::sqrt(kAdaptiveDarkFloor), 1e-9);
  EXPECT_TRUE(std::isinf(adaptive_error(PixelMoments{}, 0)));
}

}  // namespace
}  // namespace tritrace
