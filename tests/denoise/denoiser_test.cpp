// The denoiser against synthetic images with known answers, no rendering: constants stay
// constant, a noisy smooth function converges to itself as the noise falls, steps in albedo,
// normal and depth stay steps (and blur when the feature is left out, so the tests can fail),
// the mean is kept, the half-buffer variance agrees with the known variance, and the result is
// the same bits for any thread count.
#include "tritrace/denoise/denoiser.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "tritrace/error.h"
#include "tritrace/math/random.h"
#include "tritrace/render/sampler.h"

namespace tritrace {
namespace {

Image filled(int w, int h, glm::vec3 v) {
  Image image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) image.at(x, y) = v;
  }
  return image;
}

Image from_function(int w, int h, const std::function<glm::vec3(int, int)>& f) {
  Image image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) image.at(x, y) = f(x, y);
  }
  return image;
}

// Standard normal numbers by Box-Muller from PCG32, so the images are the same on any standard
// library.
class Gaussian {
 public:
  explicit Gaussian(uint64_t seed) : rng_(seed, 7) {}
  float operator()() {
    const double u1 = (static_cast<double>(rng_.next_u32()) + 0.5) * 0x1p-32;
    const double u2 = static_cast<double>(rng_.next_u32()) * 0x1p-32;
    return static_cast<float>(std::sqrt(-2.0 * std::log(u1)) *
                              std::cos(2.0 * std::numbers::pi * u2));
  }
  double uniform() { return (static_cast<double>(rng_.next_u32()) + 0.5) * 0x1p-32; }

 private:
  Pcg32 rng_;
};

Image add_noise(const Image& clean, float sigma, uint64_t seed) {
  Gaussian g(seed);
  Image noisy = clean;
  for (int y = 0; y < clean.height(); ++y) {
    for (int x = 0; x < clean.width(); ++x) {
      for (int k = 0; k < 3; ++k) noisy.at(x, y)[k] += sigma * g();
    }
  }
  return noisy;
}

double rmse(const Image& a, const Image& b) {
  double sum = 0.0;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      for (int k = 0; k < 3; ++k) {
        const double d = static_cast<double>(a.at(x, y)[k]) - b.at(x, y)[k];
        sum += d * d;
      }
    }
  }
  return std::sqrt(sum / (3.0 * a.width() * a.height()));
}

double mean(const Image& image) {
  double sum = 0.0;
  for (const glm::vec3& v : image.pixels()) sum += static_cast<double>(v.x) + v.y + v.z;
  return sum / (3.0 * static_cast<double>(image.pixels().size()));
}

// The mean of the red channel over the columns [x0, x1) of all rows.
double column_mean(const Image& image, int x0, int x1) {
  double sum = 0.0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = x0; x < x1; ++x) sum += image.at(x, y).x;
  }
  return sum / (static_cast<double>(image.height()) * (x1 - x0));
}

// Features of one flat, uniformly coloured plane facing the camera.
struct Flat {
  Image albedo, normal, depth;
  Flat(int w, int h, glm::vec3 albedo_value = glm::vec3(0.5f))
      : albedo(filled(w, h, albedo_value)),
        normal(filled(w, h, glm::vec3(0.0f, 0.0f, 1.0f))),
        depth(filled(w, h, glm::vec3(2.0f))) {}
  DenoiseFeatures features() const { return {albedo, normal, depth}; }
};

TEST(Denoiser, ConstantImageStaysConstant) {
  const int w = 97, h = 70;  // not a multiple of the tile size
  const glm::vec3 c(0.3f, 0.5f, 0.7f);
  const Image colour = filled(w, h, c);
  const Flat flat(w, h, glm::vec3(0.8f, 0.6f, 0.4f));
  DenoiseOptions plain;
  plain.demodulate_albedo = false;
  for (float variance : {0.0f, 0.01f, 10.0f}) {
    const Image v = filled(w, h, glm::vec3(variance));
    EXPECT_EQ(denoise(colour, v, flat.features(), plain).pixels(), colour.pixels())
        << "the same bits without demodulation, variance " << variance;
    // Dividing by the albedo and multiplying back rounds twice: within 2 ulp.
    const Image out = denoise(colour, v, flat.features());
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        for (int k = 0; k < 3; ++k) {
          ASSERT_NEAR(out.at(x, y)[k], c[k], 0x1p-22f * c[k])
              << "pixel (" << x << ", " << y << "), variance " << variance;
        }
      }
    }
  }
}

TEST(Denoiser, ImageWithoutNoiseAndWithoutEqualNeighboursIsKept) {
  // Zero variance: every difference in colour is signal, so no neighbour gets weight.
  const int w = 40, h = 30;
  const Image colour =
      from_function(w, h, [](int x, int y) { return glm::vec3(0.1f + 0.01f * x + 0.3f * y); });
  const Flat flat(w, h);
  const Image out = denoise(colour, filled(w, h, glm::vec3(0.0f)), flat.features());
  EXPECT_LT(rmse(out, colour), 1e-6);
}

glm::vec3 smooth_function(int x, int y, int w, int h) {
  const float u = static_cast<float>(x) / w, v = static_cast<float>(y) / h;
  const float pi = std::numbers::pi_v<float>;
  const float s = std::sin(3.0f * pi * u) * std::cos(2.0f * pi * v);
  return glm::vec3(0.5f + 0.25f * s, 0.4f + 0.2f * u, 0.6f - 0.15f * s * v);
}

TEST(Denoiser, NoisySmoothFunctionConvergesAsNoiseFalls) {
  const int w = 128, h = 128;
  const Image clean =
      from_function(w, h, [&](int x, int y) { return smooth_function(x, y, w, h); });
  const Flat flat(w, h);
  double previous = 1e30;
  for (float sigma : {0.2f, 0.1f, 0.05f, 0.025f, 0.0125f, 0.00625f}) {
    const Image noisy = add_noise(clean, sigma, 11);
    const Image out = denoise(noisy, filled(w, h, glm::vec3(sigma * sigma)), flat.features());
    const double noisy_error = rmse(noisy, clean);
    const double error = rmse(out, clean);
    EXPECT_LT(error, previous) << "sigma " << sigma;
    EXPECT_LT(error, 0.35 * noisy_error) << "sigma " << sigma << ": rmse " << error;
    previous = error;
  }
}

// Two half buffers of n samples per pixel each, their samples the clean value plus Gaussian
// noise of standard deviation sigma.
struct Halves {
  Image a, b;
};
Halves make_halves(const Image& clean, float sigma, int samples_per_half, uint64_t seed) {
  Gaussian g(seed);
  Halves halves{clean, clean};
  const float sigma_mean = sigma / std::sqrt(static_cast<float>(samples_per_half));
  for (int y = 0; y < clean.height(); ++y) {
    for (int x = 0; x < clean.width(); ++x) {
      for (int k = 0; k < 3; ++k) {
        halves.a.at(x, y)[k] += sigma_mean * g();
        halves.b.at(x, y)[k] += sigma_mean * g();
      }
    }
  }
  return halves;
}

TEST(Denoiser, HalfBuffersConvergeAsNoiseFalls) {
  const int w = 128, h = 128;
  const Image clean =
      from_function(w, h, [&](int x, int y) { return smooth_function(x, y, w, h); });
  const Flat flat(w, h);
  double previous = 1e30;
  for (int spp : {4, 16, 64, 256, 1024}) {
    const Halves halves = make_halves(clean, 0.5f, spp / 2, 23);
    const Image noisy = average_halves(halves.a, halves.b);
    const Image out = denoise_halves(halves.a, halves.b, flat.features());
    const double noisy_error = rmse(noisy, clean);
    const double error = rmse(out, clean);
    EXPECT_LT(error, previous) << spp << " spp";
    EXPECT_LT(error, 0.35 * noisy_error) << spp << " spp: rmse " << error;
    previous = error;
  }
}

// A step between the left and the right half of the image, in colour and in one feature; the
// colour step is smaller than the noise, so the colour alone cannot tell it from noise.
struct Step {
  Image colour, variance, albedo, normal, depth;
  float left, right;  // the clean red values
  DenoiseFeatures features() const { return {albedo, normal, depth}; }
};

enum class StepFeature { kAlbedo, kNormal, kDepth };

constexpr int kStepWidth = 64, kStepHeight = 512;
constexpr float kStepSigma = 0.2f;

Step make_step(StepFeature feature) {
  const int w = kStepWidth, h = kStepHeight;
  Step s{Image(),
         filled(w, h, glm::vec3(kStepSigma * kStepSigma)),
         filled(w, h, glm::vec3(0.5f)),
         filled(w, h, glm::vec3(0.0f, 0.0f, 1.0f)),
         filled(w, h, glm::vec3(2.0f)),
         0.5f,
         0.6f};
  for (int y = 0; y < h; ++y) {
    for (int x = w / 2; x < w; ++x) {
      switch (feature) {
        case StepFeature::kAlbedo:
          // The demodulated colour steps too (0.5 / 0.5 against 0.6 / 0.4).
          s.albedo.at(x, y) = glm::vec3(0.4f);
          s.left = 0.5f;
          s.right = 0.6f;
          break;
        case StepFeature::kNormal:
          s.normal.at(x, y) = glm::vec3(0.6f, 0.0f, 0.8f);
          break;
        case StepFeature::kDepth:
          s.depth.at(x, y) = glm::vec3(3.0f);
          break;
      }
    }
  }
  const Image clean =
      from_function(w, h, [&](int x, int) { return glm::vec3(x < w / 2 ? s.left : s.right); });
  s.colour = add_noise(clean, kStepSigma, 5);
  return s;
}

// How far the mean of the columns 2 to 4 pixels from the edge, on either side, is from its
// side's clean value (the larger of the two).
double step_leak(const Step& s, const Image& out) {
  const int e = kStepWidth / 2;
  const double left = std::abs(column_mean(out, e - 5, e - 2) - s.left);
  const double right = std::abs(column_mean(out, e + 2, e + 5) - s.right);
  return std::max(left, right);
}

TEST(Denoiser, AlbedoStepStaysAStep) {
  const Step s = make_step(StepFeature::kAlbedo);
  const Image out = denoise(s.colour, s.variance, s.features());
  EXPECT_LT(step_leak(s, out), 0.008);
  EXPECT_LT(rmse(out, out), 1.0);
  DenoiseOptions blind;
  blind.albedo_scale = 0.0f;
  blind.albedo_relative_scale = 0.0f;
  blind.demodulate_albedo = false;
  EXPECT_GT(step_leak(s, denoise(s.colour, s.variance, s.features(), blind)), 0.015)
      << "without the albedo the step blurs: the test can fail";
}

TEST(Denoiser, NormalStepStaysAStep) {
  const Step s = make_step(StepFeature::kNormal);
  EXPECT_LT(step_leak(s, denoise(s.colour, s.variance, s.features())), 0.008);
  DenoiseOptions blind;
  blind.normal_scale = 0.0f;
  EXPECT_GT(step_leak(s, denoise(s.colour, s.variance, s.features(), blind)), 0.015)
      << "without the normal the step blurs: the test can fail";
}

TEST(Denoiser, DepthStepStaysAStep) {
  const Step s = make_step(StepFeature::kDepth);
  EXPECT_LT(step_leak(s, denoise(s.colour, s.variance, s.features())), 0.008);
  DenoiseOptions blind;
  blind.depth_scale = 0.0f;
  EXPECT_GT(step_leak(s, denoise(s.colour, s.variance, s.features(), blind)), 0.015)
      << "without the depth the step blurs: the test can fail";
}

// Skewed noise, as Monte Carlo noise is: each pixel the mean of spp exponentially distributed
// samples around the clean value (relative standard deviation 1 / sqrt(spp) per pixel), split
// into two halves by parity.
Halves exponential_halves(const Image& clean, int spp, uint64_t seed) {
  Gaussian g(seed);
  Halves halves{Image(clean.width(), clean.height()), Image(clean.width(), clean.height())};
  for (int y = 0; y < clean.height(); ++y) {
    for (int x = 0; x < clean.width(); ++x) {
      for (int k = 0; k < 3; ++k) {
        double sums[2] = {0.0, 0.0};
        for (int s = 0; s < spp; ++s) sums[s % 2] += -clean.at(x, y)[k] * std::log(g.uniform());
        halves.a.at(x, y)[k] = static_cast<float>(sums[0] / (spp / 2));
        halves.b.at(x, y)[k] = static_cast<float>(sums[1] / (spp / 2));
      }
    }
  }
  return halves;
}

TEST(Denoiser, KeepsTheMeanOfANoisyImage) {
  const int w = 128, h = 128;
  const Image clean =
      from_function(w, h, [&](int x, int y) { return smooth_function(x, y, w, h); });
  const Flat flat(w, h);
  const Halves halves = exponential_halves(clean, 16, 31);  // 25% noise per pixel
  const Image noisy = average_halves(halves.a, halves.b);
  const Image out = denoise_halves(halves.a, halves.b, flat.features());
  EXPECT_NEAR(mean(out) / mean(noisy), 1.0, 0.005) << "clean mean " << mean(clean);
  EXPECT_LT(rmse(out, clean), 0.35 * rmse(noisy, clean));
}

// The fraction of 16 x 16 blocks (per channel) whose mean in `image` is within `tolerance` of
// its mean in `reference`.
double blocks_within(const Image& image, const Image& reference, double tolerance) {
  int blocks = 0, good = 0;
  for (int by = 0; by + 16 <= image.height(); by += 16) {
    for (int bx = 0; bx + 16 <= image.width(); bx += 16) {
      for (int k = 0; k < 3; ++k) {
        double sum = 0.0, sum_reference = 0.0;
        for (int y = by; y < by + 16; ++y) {
          for (int x = bx; x < bx + 16; ++x) {
            sum += image.at(x, y)[k];
            sum_reference += reference.at(x, y)[k];
          }
        }
        ++blocks;
        good += std::abs(sum / sum_reference - 1.0) <= tolerance ? 1 : 0;
      }
    }
  }
  return static_cast<double>(good) / blocks;
}

TEST(Denoiser, BlockMeansStayWithinThreePercentOfTheReference) {
  // Issue 24's local test against a converged reference (here the clean image): 16 x 16 block
  // means within 3% on 99% of blocks. At 64 spp (12.5% noise per pixel, 0.8% per block mean)
  // the noisy image passes, so a failure is the denoiser's.
  const int w = 256, h = 256;
  const Image clean =
      from_function(w, h, [&](int x, int y) { return smooth_function(x, y, w, h); });
  const Flat flat(w, h);
  const Halves halves = exponential_halves(clean, 64, 37);
  const Image noisy = average_halves(halves.a, halves.b);
  ASSERT_GE(blocks_within(noisy, clean, 0.03), 0.99) << "the test's premise";
  const Image out = denoise_halves(halves.a, halves.b, flat.features());
  EXPECT_GE(blocks_within(out, clean, 0.03), 0.99);
  EXPECT_GE(blocks_within(out, clean, 0.01), blocks_within(noisy, clean, 0.01))
      << "closer to the reference than the noisy image is";
}

TEST(Denoiser, SlantedPlaneIsOneSurface) {
  // Inverse depth is affine in the image on a plane seen in perspective: here it changes by
  // 0.8% of itself per pixel, 5.6% over the search radius, yet the planar prediction of depth
  // keeps the whole neighbourhood, so the plane denoises as well as a plane facing the camera.
  const int w = 128, h = 128;
  const Image clean =
      from_function(w, h, [&](int x, int y) { return smooth_function(x, y, w, h); });
  const Image noisy = add_noise(clean, 0.1f, 17);
  const Image variance = filled(w, h, glm::vec3(0.01f));
  const Flat flat(w, h);
  Flat slanted(w, h);
  slanted.depth =
      from_function(w, h, [](int x, int) { return glm::vec3(1.0f / (0.5f + 0.004f * x)); });
  const double flat_error = rmse(denoise(noisy, variance, flat.features()), clean);
  const double slanted_error = rmse(denoise(noisy, variance, slanted.features()), clean);
  EXPECT_LT(slanted_error, 1.1 * flat_error) << "flat " << flat_error;
}

// The variance of the mean of 2 n samples, Gaussian of standard deviation sigma, estimated from
// its two halves of n samples: (a - b)^2 / 4 has expectation sigma^2 / (2 n), and over P pixels
// and channels the sum of (a - b)^2 / (4 sigma^2 / (2 n)) is chi-square with P degrees of
// freedom, so its deviation from P is within 4 standard deviations, sqrt(2 P).
TEST(Denoiser, HalfBufferVarianceIsChiSquareAroundTheKnownVariance) {
  const int w = 64, h = 64, n = 8;
  const float sigma = 0.3f;
  const Halves halves = make_halves(filled(w, h, glm::vec3(1.0f)), sigma, n, 41);
  const double known = sigma * sigma / (2.0 * n);
  const Image raw = variance_from_halves(halves.a, halves.b, 0);
  double chi2 = 0.0;
  for (const glm::vec3& v : raw.pixels()) chi2 += (v.x + v.y + v.z) / known;
  const double dof = 3.0 * w * h;
  EXPECT_LT(std::abs(chi2 - dof), 4.0 * std::sqrt(2.0 * dof));
  // The smoothed estimate (5 x 5 pixels, 25 degrees of freedom away from the border) keeps the
  // mean and has about 1/5 of the raw estimate's relative spread, sqrt(2 / 25) = 0.28.
  const Image smooth = variance_from_halves(halves.a, halves.b, 2);
  double sum = 0.0, sum2 = 0.0, count = 0.0;
  for (int y = 2; y < h - 2; ++y) {
    for (int x = 2; x < w - 2; ++x) {
      for (int k = 0; k < 3; ++k) {
        const double r = smooth.at(x, y)[k] / known;
        sum += r;
        sum2 += r * r;
        count += 1.0;
      }
    }
  }
  const double mean_ratio = sum / count;
  const double spread = std::sqrt(sum2 / count - mean_ratio * mean_ratio);
  EXPECT_NEAR(mean_ratio, 1.0, 0.05);
  EXPECT_NEAR(spread, std::sqrt(2.0 / 25.0), 0.05);
}

// Against the sample variance of each pixel's own samples (what independent renders would show),
// with skewed samples as Monte Carlo gives: exponential, mean mu, variance mu^2. The two
// estimates of the variance of the mean agree in the mean over pixels, within 4 standard errors
// of their difference.
TEST(Denoiser, HalfBufferVarianceAgreesWithTheSampleVariance) {
  const int w = 64, h = 64, spp = 32;
  Gaussian g(43);
  Image a(w, h), b(w, h);
  std::vector<double> differences;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double mu = 0.2 + 0.01 * x;
      for (int k = 0; k < 3; ++k) {
        double sums[2] = {0.0, 0.0};
        double sum = 0.0, sum2 = 0.0;
        for (int s = 0; s < spp; ++s) {
          const double v = -mu * std::log(g.uniform());
          sums[s % 2] += v;
          sum += v;
          sum2 += v * v;
        }
        a.at(x, y)[k] = static_cast<float>(sums[0] / (spp / 2));
        b.at(x, y)[k] = static_cast<float>(sums[1] / (spp / 2));
        const double sample_variance = (sum2 - sum * sum / spp) / (spp - 1);
        const double d = static_cast<double>(a.at(x, y)[k]) - b.at(x, y)[k];
        // Relative to the known variance of the mean, so pixels weigh alike.
        differences.push_back((d * d / 4.0 - sample_variance / spp) / (mu * mu / spp));
      }
    }
  }
  double sum = 0.0, sum2 = 0.0;
  for (double d : differences) {
    sum += d;
    sum2 += d * d;
  }
  const double count = static_cast<double>(differences.size());
  const double mean_difference = sum / count;
  const double standard_error =
      std::sqrt((sum2 / count - mean_difference * mean_difference) / count);
  EXPECT_LT(std::abs(mean_difference), 4.0 * standard_error);
  EXPECT_LT(standard_error, 0.05) << "the test's power";
}

TEST(Denoiser, SameBitsForAnyThreadCount) {
  const int w = 150, h = 90;  // several tiles, partial ones at the edges
  const Step s = make_step(StepFeature::kNormal);
  Image colour(w, h), variance(w, h), albedo(w, h), normal(w, h), depth(w, h);
  Gaussian g(3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      colour.at(x, y) = s.colour.at(x % kStepWidth, y) * (1.0f + 0.1f * g());
      variance.at(x, y) = glm::vec3(0.01f + 0.01f * std::abs(g()));
      albedo.at(x, y) = glm::vec3(x < 70 ? 0.3f : 0.7f, 0.5f, 0.0f);  // blue: black
      normal.at(x, y) = y < 40 ? glm::vec3(0.0f) : s.normal.at(x % kStepWidth, y);
      depth.at(x, y) = glm::vec3(y < 40 ? 0.0f : 1.0f + 0.01f * x);
    }
  }
  const DenoiseFeatures features{albedo, normal, depth};
  Image one;
  tbb::task_arena(1).execute([&] { one = denoise(colour, variance, features); });
  const Image all = denoise(colour, variance, features);  // every core
  ASSERT_EQ(one.pixels().size(), all.pixels().size());
  EXPECT_EQ(std::memcmp(one.pixels().data(), all.pixels().data(),
                        one.pixels().size() * sizeof(glm::vec3)),
            0);
  EXPECT_GT(rmse(one, colour), 0.0) << "it did something";
}

TEST(Denoiser, RejectsMismatchedSizesAndNonFiniteValues) {
  const Flat flat(8, 8);
  const Image colour = filled(8, 8, glm::vec3(1.0f));
  EXPECT_THROW((void)denoise(colour, filled(8, 7, glm::vec3(0.0f)), flat.features()), Error);
  const Flat small(8, 7);
  EXPECT_THROW((void)denoise(colour, filled(8, 8, glm::vec3(0.0f)), small.features()), Error);
  Image bad = colour;
  bad.at(3, 4).y = std::nanf("");
  EXPECT_THROW((void)denoise(bad, filled(8, 8, glm::vec3(0.0f)), flat.features()), Error);
  EXPECT_THROW((void)variance_from_halves(colour, filled(7, 8, glm::vec3(0.0f))), Error);
  DenoiseOptions options;
  options.search_radius = -1;
  EXPECT_THROW((void)denoise(colour, colour, flat.features(), options), Error);
}

TEST(Denoiser, EmptyImageGivesEmptyImage) {
  const Image empty;
  const Image out = denoise(empty, empty, {empty, empty, empty});
  EXPECT_EQ(out.width(), 0);
  EXPECT_TRUE(out.pixels().empty());
}

TEST(Denoiser, EdgeOfALightGainsNoLight) {
  // A light source (albedo 0, radiance 10) beside a lit wall (albedo 0.8), with a column of
  // edge pixels that are 95% light and 5% wall, as anti-aliasing makes them; the variance is
  // estimated from the image, so it is large at the edge. Demodulated, the edge pixels' colour
  // is 9.5 / 0.043, far below the light's 10 / 0.003: if they were averaged with the light and
  // multiplied back by their own albedo they would gain light.
  const int w = 64, h = 64;
  Image colour(w, h), albedo(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const bool light = x < 20, edge = x == 20;
      albedo.at(x, y) = glm::vec3(light ? 0.0f : edge ? 0.04f : 0.8f);
      colour.at(x, y) = glm::vec3(light ? 10.0f : edge ? 9.525f : 0.5f);
    }
  }
  Image noisy = add_noise(colour, 0.05f, 53);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < 20; ++x) noisy.at(x, y) = colour.at(x, y);  // a light has no noise
  }
  const Flat flat(w, h);
  const DenoiseFeatures features{albedo, flat.normal, flat.depth};
  const Image variance = estimate_variance_spatially(noisy, albedo);
  const Image out = denoise(noisy, variance, features);
  float largest = 0.0f;
  for (const glm::vec3& v : out.pixels()) largest = std::max({largest, v.x, v.y, v.z});
  EXPECT_LT(largest, 10.5f);
  EXPECT_NEAR(mean(out) / mean(noisy), 1.0, 0.005);
  DenoiseOptions absolute_only;
  absolute_only.albedo_relative_scale = 0.0f;
  const Image wrong = denoise(noisy, variance, features, absolute_only);
  float wrong_largest = 0.0f;
  for (const glm::vec3& v : wrong.pixels())
    wrong_largest = std::max({wrong_largest, v.x, v.y, v.z});
  EXPECT_GT(wrong_largest, 10.5f) << "comparing albedos in absolute terms only gains light";
}

// A noisy smooth image with a soft shadow's edge that no feature sees, from independent half
// buffers (exact variance), against the known clean image, through the first pass alone, the
// guided pass alone (sure_radius -1) and the default (the two blended by their SURE).
// The guided pass lowers the error at 4 spp; its k (3) was tuned on rendered scenes
// (docs/DENOISING.md), and on this image it gains less as the spp grow (at 64 spp it is 1.01x the
// first pass), which the blend catches: it is never far from the better of the two (measured:
// 1.05x and 1.02x the guided pass at 4 and 16 spp, 0.96x the first pass at 64; with the guided
// k of 4 before the variance floor: 1.05x, 0.99x and 0.98x).
TEST(Denoiser, GuidedPassAndTheSureBlend) {
  const int w = 128, h = 128;
  const Image clean = from_function(w, h, [&](int x, int y) {
    const glm::vec3 c = smooth_function(x, y, w, h);
    return x + y < 120 ? c * 0.4f : c;  // a soft shadow's edge, diagonal
  });
  const Flat flat(w, h);
  for (int spp : {4, 16, 64}) {
    const Halves halves = make_halves(clean, 0.5f, spp / 2, 47);
    DenoiseOptions one_pass, guided;
    one_pass.guided_pass = false;
    guided.sure_radius = -1;
    const double noisy = rmse(average_halves(halves.a, halves.b), clean);
    const double one = rmse(denoise_halves(halves.a, halves.b, flat.features(), one_pass), clean);
    const double two = rmse(denoise_halves(halves.a, halves.b, flat.features(), guided), clean);
    const double chosen = rmse(denoise_halves(halves.a, halves.b, flat.features()), clean);
    const std::string what = std::to_string(spp) + " spp: one pass " + std::to_string(one) +
                             ", guided " + std::to_string(two) + ", blended " +
                             std::to_string(chosen) + ", noisy " + std::to_string(noisy);
    std::printf("%s\n", what.c_str());
    if (spp == 4) {
      EXPECT_LT(two, 0.95 * one) << what;
    }
    EXPECT_LT(chosen, 1.1 * std::min(one, two)) << what;
    EXPECT_LT(chosen, 0.2 * noisy) << what;
  }
}

// Fireflies: 1 sample in 256 is 100 times the others (the mean of each pixel's samples is still
// mu). The weighted means alone do not keep the total around them; keep_mean restores each
// channel's sum, so the image mean is the noisy image's within float rounding, and the fireflies
// are spread (their pixels' error falls).
TEST(Denoiser, KeepsTheMeanAroundFireflies) {
  const int w = 96, h = 96, spp = 16;
  const Flat flat(w, h);
  Pcg32 rng(9, 4);
  Image a(w, h), b(w, h);
  const double mu = 0.3, low = mu / (255.0 / 256.0 + 100.0 / 256.0), high = 100.0 * low;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int k = 0; k < 3; ++k) {
        double sums[2] = {0.0, 0.0};
        for (int s = 0; s < spp; ++s) sums[s % 2] += rng.next_u32() % 256 == 0 ? high : low;
        a.at(x, y)[k] = static_cast<float>(sums[0] / (spp / 2));
        b.at(x, y)[k] = static_cast<float>(sums[1] / (spp / 2));
      }
    }
  }
  const Image noisy = average_halves(a, b);
  const Image clean = filled(w, h, glm::vec3(static_cast<float>(mu)));
  const Image out = denoise_halves(a, b, flat.features());
  EXPECT_NEAR(mean(out) / mean(noisy), 1.0, 1e-5);
  EXPECT_LT(rmse(out, clean), 0.5 * rmse(noisy, clean));
}

// The renderer's half buffers (samples split by index parity) with its own Sampler. The oracle
// is the variance of the pixel mean over 4096 pixels, each an independent scramble of the same
// integrand (what independent seeds show). With independent samples (a - b)^2 / 4 is unbiased;
// with the Sobol sampler the halves' errors are negatively correlated (each half holds one point
// of every pair 2i, 2i + 1, which lie in opposite halves of every dimension), so it comes out
// larger, never smaller. By how much depends on the integrand: a few low dimensions with an edge
// (a pixel's footprint times a light with a visibility edge) give 10 - 25, a path of several
// bounces (each a product over its own 2-D group) gives less, and cornell-area's pixels give
// 1.6 - 2.3 (docs/DENOISING.md), whence kSobolHalfBufferVarianceRatio = 2.
TEST(Denoiser, HalfBufferVarianceOfTheSobolSamplerOverestimatesTheVariance) {
  auto direct = [](Sampler& sampler) {
    const glm::vec2 film = sampler.get_2d();
    const glm::vec2 light = sampler.get_2d();
    const double footprint = 0.6 + 0.4 * film.x * film.y;
    return footprint * (light.x + 0.3 * light.y < 0.8 ? 1.0 : 0.0) * (1.0 + light.y);
  };
  auto path = [](Sampler& sampler) {
    double throughput = 1.0, sum = 0.0;
    for (int bounce = 0; bounce < 4; ++bounce) {
      const glm::vec2 light = sampler.get_2d();
      const glm::vec2 direction = sampler.get_2d();
      sum += throughput * (light.x < 0.7 ? 1.0 : 0.0) * (0.5 + light.y);
      throughput *= 1.2 * direction.x + 0.4 * direction.y * direction.y;
    }
    return sum;
  };
  const int pixels = 4096;
  for (SamplerKind kind : {SamplerKind::kIndependent, SamplerKind::kSobol}) {
    for (int integrand = 0; integrand < 2; ++integrand) {
      for (int spp : {16, 64}) {
        Sampler sampler(5, kind);
        double sum = 0.0, sum2 = 0.0, half_buffer = 0.0;
        for (int p = 0; p < pixels; ++p) {
          double halves[2] = {0.0, 0.0};
          for (int s = 0; s < spp; ++s) {
            sampler.start_pixel_sample(p % 64, p / 64, static_cast<uint32_t>(s));
            halves[s % 2] += integrand == 0 ? direct(sampler) : path(sampler);
          }
          const double a = halves[0] / (spp / 2), b = halves[1] / (spp / 2);
          const double m = 0.5 * (a + b);
          sum += m;
          sum2 += m * m;
          half_buffer += (a - b) * (a - b) / 4.0;
        }
        const double variance = (sum2 - sum * sum / pixels) / (pixels - 1);
        const double ratio = half_buffer / pixels / variance;
        std::printf("%s integrand %d spp %d: half-buffer / variance %.3f\n",
                    kind == SamplerKind::kSobol ? "sobol" : "independent", integrand, spp, ratio);
        if (kind == SamplerKind::kIndependent) {
          // Both estimates have a relative standard error of about sqrt(2 / 4096) = 2.2%.
          EXPECT_NEAR(ratio, 1.0, 0.15) << "integrand " << integrand << ", " << spp << " spp";
        } else {
          EXPECT_GT(ratio, 1.3) << "integrand " << integrand << ", " << spp << " spp";
        }
      }
    }
  }
}

// smooth_variance divides by the overestimate after the 5 x 5 mean: on a constant AOV the result
// is the constant over the ratio.
TEST(Denoiser, SmoothVarianceDividesByTheOverestimate) {
  const Image v = filled(9, 7, glm::vec3(0.2f, 0.4f, 0.8f));
  const Image s = smooth_variance(v);
  EXPECT_NEAR(s.at(4, 3).x, 0.1f, 1e-7f);
  EXPECT_NEAR(s.at(0, 0).z, 0.4f, 1e-7f);
  EXPECT_NEAR(smooth_variance(v, 2, 1.0f).at(8, 6).y, 0.4f, 1e-7f);
  EXPECT_THROW((void)smooth_variance(v, 2, 0.0f), Error);
}

// The SURE window is checked like the search radius: above 32 is an error, any negative value
// means the guided pass alone.
TEST(Denoiser, RejectsASureRadiusAbove32) {
  const Image c = filled(8, 8, glm::vec3(0.5f));
  const Flat flat(8, 8);
  DenoiseOptions options;
  options.sure_radius = 33;
  EXPECT_THROW((void)denoise(c, c, flat.features(), options), Error);
  options.sure_radius = -5;
  EXPECT_EQ(denoise(c, c, flat.features(), options).pixels().size(), 64u);
}

TEST(Denoiser, RejectsBadBrightEdgeSettings) {
  const Image c = filled(8, 8, glm::vec3(0.5f));
  const Flat flat(8, 8);
  for (const int radius : {0, 5}) {
    DenoiseOptions options;
    options.bright_edges.radius = radius;
    EXPECT_THROW((void)denoise(c, c, flat.features(), options), Error) << radius;
  }
  for (const float v : {-1.0f, std::nanf("")}) {
    DenoiseOptions options;
    options.bright_edges.max_chi2 = v;
    EXPECT_THROW((void)denoise(c, c, flat.features(), options), Error) << v;
  }
  DenoiseOptions off;
  off.bright_edges.contrast = 0.0f;  // off, not an error
  EXPECT_EQ(denoise(c, c, flat.features(), off).pixels().size(), 64u);
}

// The variance the filter uses is at least spatial_variance_floor (0.5) times the image's own
// estimate (estimate_variance_spatially), but at most spatial_variance_floor_limit (16) times the
// given variance. A noisy image (sigma 0.1) given a variance 200 times too small: with the
// default the filter uses 16 times it (the limit, below half the spatial estimate everywhere
// here), so it denoises as the given variance times 16 with the floor off does (within rounding:
// one multiplies where the other divides by the albedo), closer to the known clean image than
// with the floor off (measured: 0.93 and 1.00 of the noise). Without the limit it denoises as
// half the spatial estimate given, and removes most of the noise (0.21). A variance of 0 returns
// the image unchanged.
TEST(Denoiser, SpatialVarianceFloorIsHalfTheImagesOwnEstimateUpToALimit) {
  const int w = 48, h = 40;
  const Image clean =
      from_function(w, h, [&](int x, int y) { return smooth_function(x, y, w, h); });
  const Image noisy = add_noise(clean, 0.1f, 71);
  const Flat flat(w, h);
  const auto largest_difference = [&](const Image& a, const Image& b) {
    float largest = 0.0f;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        for (int k = 0; k < 3; ++k) {
          largest = std::max(largest, std::abs(a.at(x, y)[k] - b.at(x, y)[k]));
        }
      }
    }
    return largest;
  };
  const float small = 0.01f / 200.0f;
  const Image floored = denoise(noisy, filled(w, h, glm::vec3(small)), flat.features());
  DenoiseOptions no_floor;
  no_floor.spatial_variance_floor = 0.0f;
  EXPECT_LT(largest_difference(floored, denoise(noisy, filled(w, h, glm::vec3(16.0f * small)),
                                                flat.features(), no_floor)),
            1e-4f);
  const double noise = rmse(noisy, clean);
  EXPECT_LT(rmse(floored, clean),
            0.97 * rmse(denoise(noisy, filled(w, h, glm::vec3(small)), flat.features(), no_floor),
                        clean));

  DenoiseOptions unlimited;
  unlimited.spatial_variance_floor_limit = 1e30f;
  Image half = estimate_variance_spatially(noisy, flat.albedo);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) half.at(x, y) *= 0.5f;
  }
  const Image half_floored =
      denoise(noisy, filled(w, h, glm::vec3(1e-20f)), flat.features(), unlimited);
  EXPECT_LT(largest_difference(half_floored, denoise(noisy, half, flat.features(), no_floor)),
            1e-4f);
  EXPECT_LT(rmse(half_floored, clean), 0.5 * noise);
  std::printf(
      "RMSE / noise: floored %.3f, limited %.3f, floor off %.3f\n",
      rmse(half_floored, clean) / noise, rmse(floored, clean) / noise,
      rmse(denoise(noisy, filled(w, h, glm::vec3(small)), flat.features(), no_floor), clean) /
          noise);

  const Image zero = filled(w, h, glm::vec3(0.0f));
  EXPECT_LT(rmse(denoise(noisy, zero, flat.features()), noisy), 1e-7);
  no_floor.spatial_variance_floor = -1.0f;
  EXPECT_THROW((void)denoise(noisy, zero, flat.features(), no_floor), Error);
}

// Issue 24's cornell-area goal missed on some seeds at the light's edge: a pixel that the light
// covers by a small fraction gets, at 16 spp, either no sample on the light or one (10 / 16 of
// the light's radiance, many times its true value), and the half-buffer variance, smoothed
// among its neighbours, called that exact. Here a light (radiance 10, albedo 0, exact) beside a
// wall (mean 0.05, albedo 0.5, noisy), and between them a column of pixels 0.5% covered by the
// light, each from 16 samples split into half buffers as the renderer splits them. Against the
// known image: the light and the wall stay a step (no light leaks onto the wall beyond the edge
// column, the light keeps its radiance), the edge column's relative error (the bench's measure)
// falls to below 0.6 of the noisy one's, and the mean stays the noisy image's. Measured 0.35,
// and 0.34 with spatial_variance_floor 0: where a whole column of edge pixels is alike the
// filter averages along it either way; the floor's gain is at an isolated edge pixel among
// unlike neighbours (docs/DENOISING.md), which the test above checks the mechanism for.
TEST(Denoiser, EdgeOfABrightLightStaysAStepAndItsCoverageNoiseFalls) {
  const int w = 48, h = 48, spp = 16, edge = 20;
  const float coverage = 0.005f, radiance = 10.0f, wall = 0.05f;
  const double truth = coverage * radiance + (1.0f - coverage) * wall;
  double noisy_error = 0.0, error = 0.0;
  for (uint64_t seed = 1; seed <= 2; ++seed) {
    Gaussian rng(seed);
    Image a(w, h), b(w, h), albedo(w, h);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        glm::vec3 sum_a(0.0f), sum_b(0.0f), sum_albedo(0.0f);
        for (int s = 0; s < spp; ++s) {
          const bool light = x < edge || (x == edge && rng.uniform() < coverage);
          const float v = light ? radiance : wall * static_cast<float>(0.5 + rng.uniform());
          (s % 2 == 0 ? sum_a : sum_b) += glm::vec3(v);
          sum_albedo += glm::vec3(light ? 0.0f : 0.5f);
        }
        a.at(x, y) = sum_a / (spp / 2.0f);
        b.at(x, y) = sum_b / (spp / 2.0f);
        albedo.at(x, y) = sum_albedo / static_cast<float>(spp);
      }
    }
    const Flat flat(w, h);
    const Image noisy = average_halves(a, b);
    const Image out = denoise_halves(a, b, {albedo, flat.normal, flat.depth});
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < edge; ++x) {
        EXPECT_NEAR(out.at(x, y).x, radiance, 0.01f) << x << ", " << y;
      }
      for (int x = edge + 2; x < w; ++x) EXPECT_LT(out.at(x, y).x, 0.065f) << x << ", " << y;
      const double scale = truth * truth + 0.01;
      noisy_error += (noisy.at(edge, y).x - truth) * (noisy.at(edge, y).x - truth) / scale;
      error += (out.at(edge, y).x - truth) * (out.at(edge, y).x - truth) / scale;
    }
    EXPECT_NEAR(column_mean(out, edge + 2, w) / column_mean(noisy, edge + 2, w), 1.0, 0.03);
    EXPECT_NEAR(mean(out) / mean(noisy), 1.0, 0.005);
  }
  std::printf("edge column relative error / noisy: %.3f\n", std::sqrt(error / noisy_error));
  EXPECT_LT(std::sqrt(error / noisy_error), 0.6);
}

// The bright-edge model (bright_edges.h). The coverage of a pixel by the half-plane right of the
// line x = a + b y, by the midpoint rule over 20000 strips of the pixel's height: an oracle
// independent of pixel_coverage's closed form (the integrand is piecewise linear, so the rule's
// error is below 1e-7).
double coverage_right_of(double a, double b, int px, int py) {
  // Wholly on one side: the line's x over the pixel's rows lies between its values at the two
  // row edges.
  const double x0 = a + b * py, x1 = a + b * (py + 1);
  if (px + 1 <= std::min(x0, x1)) return 0.0;
  if (px >= std::max(x0, x1)) return 1.0;
  constexpr int kStrips = 20000;
  double sum = 0.0;
  for (int i = 0; i < kStrips; ++i) {
    const double t = py + (i + 0.5) / kStrips;
    sum += std::clamp(px + 1.0 - (a + b * t), 0.0, 1.0);
  }
  return sum / kStrips;
}

TEST(Denoiser, PixelCoverageIsTheAreaOfThePixelBesideTheLine) {
  // Lines x = a + b y near the pixel [0, 1)^2: pixel_coverage(n, n . centre - d) is the
  // fraction of the pixel on the side n . x >= d of the line n . x = d, here with n pointing
  // right (the U, V of its definition are symmetric about 0).
  for (const double b : {0.0, 0.1, 0.27, 0.5, 1.0, 2.5, -0.6}) {
    for (const double a : {-2.0, -0.8, -0.3, 0.0, 0.2, 0.45, 0.7, 1.1}) {
      const double norm = std::sqrt(1.0 + b * b);
      const double nx = 1.0 / norm, ny = -b / norm, d = a / norm;  // n . (x, y) = d on the line
      const double s = nx * 0.5 + ny * 0.5 - d;                    // > 0: centre right of it
      EXPECT_NEAR(pixel_coverage(nx, ny, s), coverage_right_of(a, b, 0, 0), 1e-6)
          << "a " << a << " b " << b;
    }
  }
}

struct SlantedLight {
  static constexpr int kSize = 40;
  static constexpr double kA = 14.3, kB = 0.27;  // the light is right of x = kA + kB y
  static constexpr float kRadiance = 10.0f, kWall = 0.05f;
  std::vector<double> coverage = std::vector<double>(kSize * kSize);
  SlantedLight() {
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) coverage[y * kSize + x] = coverage_right_of(kA, kB, x, y);
    }
  }
  double truth(int x, int y) const {
    const double c = coverage[y * kSize + x];
    return c * kRadiance + (1.0 - c) * kWall;
  }
};

// Renders SlantedLight with `spp` independent uniform positions per pixel (the wall's radiance
// noisy by a factor in [0.5, 1.5)), split into halves by sample parity, and denoises it.
struct SlantedRender {
  Image noisy, out;
  SlantedRender(int spp, uint64_t seed, const DenoiseOptions& options) {
    const int n = SlantedLight::kSize;
    Gaussian rng(seed);
    Image a(n, n), b(n, n), albedo(n, n);
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        glm::vec3 sum_a(0.0f), sum_b(0.0f), sum_albedo(0.0f);
        for (int s = 0; s < spp; ++s) {
          const double px = x + rng.uniform(), py = y + rng.uniform();
          const bool lit = px > SlantedLight::kA + SlantedLight::kB * py;
          const float v = lit ? SlantedLight::kRadiance
                              : SlantedLight::kWall * static_cast<float>(0.5 + rng.uniform());
          (s % 2 == 0 ? sum_a : sum_b) += glm::vec3(v);
          sum_albedo += glm::vec3(lit ? 0.0f : 0.8f);
        }
        a.at(x, y) = sum_a / (spp / 2.0f);
        b.at(x, y) = sum_b / (spp / 2.0f);
        albedo.at(x, y) = sum_albedo / static_cast<float>(spp);
      }
    }
    const Flat flat(n, n);
    noisy = average_halves(a, b);
    out = denoise_halves(a, b, {albedo, flat.normal, flat.depth}, options);
  }
};

TEST(Denoiser, SlantedEdgeOfALightStaysAStepAndItsPartlyCoveredPixelsConverge) {
  const SlantedLight light;
  const int n = SlantedLight::kSize;
  DenoiseOptions off;
  off.bright_edges.contrast = 0.0f;
  double previous = 1e30;
  for (const int spp : {16, 64}) {
    // Per pixel that the edge crosses: the squared error relative to (truth^2 + 0.01) (the
    // relMSE of docs/DENOISING.md); separately the pixels covered by less than 15%, which at 16
    // spp often get no sample on the light and then look like the wall in every feature.
    double noisy_error = 0.0, error = 0.0, error_off = 0.0, low = 0.0, low_off = 0.0;
    int edge_pixels = 0, low_pixels = 0;
    for (uint64_t seed = 1; seed <= 2; ++seed) {
      const SlantedRender with(spp, seed, {});
      const SlantedRender without(spp, seed, off);
      if (spp == 16 && seed == 1) {
        // The fits read only the inputs and the filter's result: the same bits on one thread.
        std::optional<SlantedRender> one;
        tbb::task_arena(1).execute([&] { one.emplace(spp, seed, DenoiseOptions{}); });
        EXPECT_EQ(std::memcmp(one->out.pixels().data(), with.out.pixels().data(),
                              with.out.pixels().size() * sizeof(glm::vec3)),
                  0);
      }
      EXPECT_NEAR(mean(with.out) / mean(with.noisy), 1.0, 0.005);
      for (int y = 0; y < n; ++y) {
        for (int x = 0; x < n; ++x) {
          const double c = light.coverage[y * n + x], truth = light.truth(x, y);
          const double scale = truth * truth + 0.01;
          if (c >= 1.0) {
            EXPECT_NEAR(with.out.at(x, y).x, SlantedLight::kRadiance, 0.01) << x << ", " << y;
          } else if (c <= 0.0 &&
                     coverage_right_of(SlantedLight::kA - 2.0, SlantedLight::kB, x, y) <= 0.0) {
            // Two pixels or more left of the edge: the wall, not lit by the light.
            EXPECT_LT(with.out.at(x, y).x, 0.08f) << x << ", " << y;
          } else if (c > 0.0) {
            const auto sq = [&](const Image& image) {
              const double d = image.at(x, y).x - truth;
              return d * d / scale;
            };
            noisy_error += sq(with.noisy);
            error += sq(with.out);
            error_off += sq(without.out);
            ++edge_pixels;
            if (c < 0.15) {
              low += sq(with.out);
              low_off += sq(without.out);
              ++low_pixels;
            }
          }
        }
      }
    }
    std::printf(
        "%d spp, %d edge pixels: error / noisy %.3f (model off %.3f); %d below 15%%: "
        "%.4f (off %.4f)\n",
        spp, edge_pixels, std::sqrt(error / noisy_error), std::sqrt(error_off / noisy_error),
        low_pixels, low / low_pixels, low_off / low_pixels);
    // Measured: 0.79 and 0.80 of the noisy error at 16 and 64 spp (the filter alone 0.99 and
    // 1.13); below 15% coverage 0.42 and 0.10 (the filter alone 0.64 and 0.20).
    EXPECT_LT(error, 0.9 * noisy_error);
    EXPECT_LT(error, 0.9 * error_off);
    EXPECT_LT(low, 0.8 * low_off);
    EXPECT_LT(error, previous);
    previous = error;
  }
}

}  // namespace
}  // namespace tritrace
