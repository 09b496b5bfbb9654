// Adaptive sampling (--noise-threshold): decisions from each pixel's own samples only, so the film
// is the same for any thread count and tile size; each pixel is exactly the uniform render of the
// samples it took (the block tree adds zeros for the samples it did not take); flat pixels stop
// at the first stop allowed (64: below T there and below sqrt(2) T at 32) and noisy ones go on; the
// image mean stays that of uniform sampling.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
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

// A pixel that took n samples is one of: the uniform render of n spp, bit for bit (its halves
// stopped together, or it reached the most; the block tree adds zeros for the samples it did not
// take), or, when one half stopped at m < n, the average of that half's partner's mean over
// [0, m) and its own half's mean over [0, n), the cross estimates, computed here from uniform
// films' totals and even half buffers: an oracle that shares nothing with the stopping rule.
TEST_F(AdaptiveTest, EachPixelIsTheUniformRenderOfTheSamplesItTookOrItsHalvesCrossEstimates) {
  const uint32_t spp = 128;
  RenderStats stats;
  const Film adaptive =
      film({.threads = 2, .spp = spp, .noise_threshold = 0.05f}, kSppAndVariance, &stats);
  const Image image = adaptive.resolve();
  const Image taken = adaptive.resolve_spp();
  const uint32_t counts[] = {32u, 64u, 128u};
  std::vector<Film> uniform;
  std::vector<Image> uniform_images;
  for (uint32_t n : counts) {
    uniform.push_back(film({.threads = 2, .spp = n}, AovSet{.variance = true}));
    uniform_images.push_back(uniform.back().resolve());
  }
  // Half h's mean over [0, counts[k]) at pixel (x, y): h 0 the even samples, 1 the odd.
  const auto half_mean = [&](size_t k, int h, int x, int y) {
    const glm::dvec4 total(uniform[k].pixel_sums(x, y));
    const glm::dvec4 even(uniform[k].pixel_aov_sums(x, y).even);
    const glm::dvec4 sums = h == 0 ? even : total - even;
    return glm::dvec3(sums) / sums.w;
  };
  double total = 0.0;
  size_t crossed = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const float n = taken.at(x, y).x;
      total += n;
      size_t k_n = std::size(counts);
      for (size_t k = 0; k < std::size(counts); ++k) {
        if (static_cast<float>(counts[k]) == n) k_n = k;
      }
      ASSERT_LT(k_n, std::size(counts)) << "pixel " << x << "," << y << " took " << n;
      const glm::vec3 got = image.at(x, y);
      if (got == uniform_images[k_n].at(x, y)) continue;
      bool found = false;
      for (size_t m = 0; m < k_n && !found; ++m) {
        for (int stopped = 0; stopped < 2 && !found; ++stopped) {
          const glm::dvec3 want = 0.5 * (half_mean(m, 1 - stopped, x, y) +
                                         half_mean(k_n, stopped, x, y));
          const glm::dvec3 d = glm::abs(glm::dvec3(got) - want);
          found = std::max({d.x, d.y, d.z}) <= 1e-5 * (1.0 + std::max({want.x, want.y, want.z}));
        }
      }
      EXPECT_TRUE(found) << x << "," << y << " at " << n << " spp";
      crossed += found;
    }
  }
  // Some pixels' halves stopped apart, or the test would show nothing of the cross estimates.
  EXPECT_GT(crossed, 0u);
  // The statistics count the samples taken, as the AOV does.
  EXPECT_EQ(static_cast<double>(stats.samples), total);
  EXPECT_EQ(stats.pixels, 40u * 24u);
  EXPECT_EQ(stats.spp, spp);
}

// The light's pixels see constant emission: zero variance, so they stop as soon as a pixel can:
// at 64, the second check (the first only confirms).
// Pixels whose half buffers (an estimate the stopping rule does not use) show a relative error
// far above the threshold at 32 spp go on past 64.
TEST(AdaptiveSampling, FlatPixelsStopAtTheFirstChanceAndNoisyOnesGoOn) {
  // Large enough that the light covers whole pixels.
  const Scene scene = make_cornell_area({.width = 96, .height = 96});
  const auto accel = make_accel(AccelKind::kBvh, scene, kDefaultKernel);
  const PathIntegrator integrator(scene);
  const auto film = [&](RenderOptions options, AovSet aovs) {
    Film f(96, 96, aovs);
    render_to_film(scene, *accel, integrator, f, options);
    return f;
  };
  const float threshold = 0.02f;
  const Film first = film({.threads = 2, .spp = 32}, {.variance = true});
  const Image mean = first.resolve(), variance = first.resolve_variance();
  const Image taken =
      film({.threads = 2, .spp = 128, .noise_threshold = threshold}, {.spp = true}).resolve_spp();
  size_t flat = 0, noisy = 0, noisy_on = 0;
  for (int y = 0; y < mean.height(); ++y) {
    for (int x = 0; x < mean.width(); ++x) {
      const glm::vec3 m = mean.at(x, y), v = variance.at(x, y);
      const float n = taken.at(x, y).x;
      // Every sample saw the light (a pixel that is part light, part its unlit back, can have
      // equal halves and a smaller mean).
      if (m == kAreaLightRadiance && v == glm::vec3(0.0f)) {
        ++flat;
        EXPECT_EQ(n, 64.0f) << x << "," << y;
      }
      const float luminance = 0.2126f * m.x + 0.7152f * m.y + 0.0722f * m.z;
      const float var = 0.2126f * v.x + 0.7152f * v.y + 0.0722f * v.z;
      if (std::sqrt(var) >
          8.0f * threshold * std::sqrt(std::max(luminance, float(kAdaptiveDarkFloor)))) {
        ++noisy;
        noisy_on += n > 64.0f;
      }
    }
  }
  EXPECT_GT(flat, 10u);
  EXPECT_GT(noisy, 10u);
  EXPECT_GE(static_cast<double>(noisy_on), 0.95 * static_cast<double>(noisy));
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
  static constexpr float kChance = 1.0f / 64.0f;
  static constexpr float kFlash = 64.0f;
  uint64_t radiance(const SampleBatch& batch, const SampleOutput& out, const Scene&,
                    const Accel&) const override {
    for (size_t i = 0; i < batch.rays.size(); ++i) {
      out.radiance[i] = glm::vec3(batch.samplers[i].get_1d() < kChance ? kFlash : 0.0f);
    }
    return 0;
  }
};

// A stopping rule that reads the samples it averages is biased here: a pixel whose samples have
// not yet met the flash has zero sample variance and stops at 64 with 0, one that has met it goes
// on to dilute it (for independent samples the mean falls to 1 - 0.75 (1 - 1/64)^64, about 0.73,
// under that rule). The cross estimates of the two halves must keep the image mean at 1 within 4
// standard errors (from the spread of the per-seed image means), with the Sobol sampler (whose
// halves are not independent) and the independent one.
TEST(AdaptiveUnbiased, RareBrightSamplesKeepTheImageMean) {
  const Scene scene = make_cornell_area({.width = 32, .height = 32});
  const auto accel = make_accel(AccelKind::kBrute, scene, kDefaultKernel);
  const RareFlash integrator;
  for (SamplerKind kind : {SamplerKind::kSobol, SamplerKind::kIndependent}) {
    constexpr int kSeeds = 8;
    std::vector<double> means;
    double samples = 0.0;
    for (int s = 0; s < kSeeds; ++s) {
      RenderStats stats;
      const Image im = render(scene, *accel, integrator,
                              {.threads = 2, .spp = 256, .seed = uint64_t(s), .sampler = kind,
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
    EXPECT_LT(std::abs(m - expected), 4.0 * se)
        << "sampler " << static_cast<int>(kind) << ": " << m << " vs " << expected << ", se " << se;
    // Pixels that met no flash stopped early, or the test would show nothing.
    EXPECT_LT(samples / kSeeds, 250.0);
  }
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
  // adaptive_spp: the passes end where the one call does, and only there does a pixel still on
  // take its cross estimates.
  const RenderOptions whole{.threads = 1, .spp = 200, .noise_threshold = 0.05f, .adaptive_spp = 200};
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
  // A pixel still on at 200 was not stopped by the check at 128; the state says active for it
  // and for no other pixel.
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
