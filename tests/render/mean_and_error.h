// Test helpers for Monte Carlo agreement checks: the mean of K independent estimates with its
// standard error from their spread, a check that two such means agree, and the image helpers the
// bdpt tests share (an image's mean over channels, bit-for-bit equality, the mean of K renders).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "tritrace/image/image.h"
#include "tritrace/render/renderer.h"

namespace tritrace::testing_mc {

struct MeanAndError {
  double mean = 0.0, error = 0.0;
};

// The mean of estimate(0), ..., estimate(k - 1) and its standard error.
template <typename Estimate>
MeanAndError mean_of(int k, Estimate&& estimate) {
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < k; ++i) {
    const double m = estimate(i);
    sum += m;
    sum2 += m * m;
  }
  const double mean = sum / k;
  return {mean, std::sqrt(std::max(0.0, sum2 / k - mean * mean) / (k - 1.0))};
}

// Two estimates agree within four combined standard errors, and the test has power: the combined
// error is below `power` times the mean.
inline void expect_same_mean(MeanAndError a, MeanAndError b, double power) {
  const double error = std::sqrt(a.error * a.error + b.error * b.error);
  std::printf("  %.6f +- %.6f vs %.6f +- %.6f (z %.2f)\n", a.mean, a.error, b.mean, b.error,
              (a.mean - b.mean) / error);
  EXPECT_GT(b.mean, 0.0);
  EXPECT_LT(std::abs(a.mean - b.mean), 4.0 * error);
  EXPECT_LT(error, power * b.mean);
}

// The mean over every pixel and channel of an image, in double.
inline double luminance_mean(const Image& image) {
  double sum = 0.0;
  for (const glm::vec3& p : image.pixels()) sum += (p.x + p.y + p.z) / 3.0;
  return sum / static_cast<double>(image.pixels().size());
}

// The same size and the same bits in every pixel.
inline bool same_bits(const Image& a, const Image& b) {
  return a.width() == b.width() && a.height() == b.height() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)) ==
             0;
}

// The image mean (luminance_mean) of k renders of `scene` with seeds seed, seed + 1, ..., at spp,
// as MeanAndError.
inline MeanAndError mean_of_renders(const Scene& scene, const Accel& accel,
                                    const Integrator& integrator, uint32_t spp, uint64_t seed,
                                    int k) {
  return mean_of(k, [&](int i) {
    return luminance_mean(render(scene, accel, integrator, {.spp = spp, .seed = seed + i}));
  });
}

}  // namespace tritrace::testing_mc
