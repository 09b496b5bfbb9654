// The film and its pixel filters: sums and resolution, the box filter's sample positions, and the
// Gaussian and Blackman-Harris filters' sampling against their own shapes (chi-square of the
// positions, and weighted moments against quadrature of the filter).
#include "tritrace/render/film.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "../math/chi_square.h"
#include "tritrace/render/sampler.h"

namespace tritrace {
namespace {

TEST(Film, ResolvesWeightedMeans) {
  Film film(2, 1, AovSet{.albedo = true, .depth = true});
  film.add(0, 0, {.radiance = glm::vec3(1.0f), .albedo = glm::vec3(0.5f), .depth = 2.0f}, 1.0f);
  film.add(0, 0, {.radiance = glm::vec3(4.0f), .albedo = glm::vec3(1.0f), .depth = 4.0f}, 3.0f);
  const Image image = film.resolve();
  EXPECT_EQ(image.at(0, 0), glm::vec3(13.0f / 4.0f));
  EXPECT_EQ(image.at(1, 0), glm::vec3(0.0f)) << "no sample: black, not NaN";
  EXPECT_EQ(film.resolve_albedo().at(0, 0), glm::vec3(3.5f / 4.0f));
  EXPECT_EQ(film.resolve_depth().at(0, 0), glm::vec3(14.0f / 4.0f));
  EXPECT_TRUE(film.resolve_normal().pixels().empty()) << "not kept";
}

TEST(Film, OneUnitSampleResolvesToItselfBitForBit) {
  Film film(1, 1);
  const glm::vec3 v(0.1f, 1.0f / 3.0f, 7e-30f);
  film.add(0, 0, {.radiance = v}, 1.0f);
  EXPECT_EQ(film.resolve().at(0, 0), v);
}

TEST(PixelFilter, BoxIsTheSampleItselfWithUnitWeight) {
  const PixelFilter box(FilterKind::kBox);
  const PixelFilter::Sample s = box.sample(0.25f, 0.875f);
  EXPECT_EQ(s.x, 0.25f);
  EXPECT_EQ(s.y, 0.875f);
  EXPECT_EQ(s.weight, 1.0f);
}

TEST(PixelFilter, NamesRoundTrip) {
  for (FilterKind k : {FilterKind::kBox, FilterKind::kGaussian, FilterKind::kBlackmanHarris}) {
    EXPECT_EQ(parse_filter(filter_name(k)), k);
  }
  EXPECT_FALSE(parse_filter("mitchell"));
}

class FilterSampling : public ::testing::TestWithParam<FilterKind> {};

// The sampled offsets along x follow the filter's tabulated density: chi-square over 32 bins
// whose expected counts integrate |f| by quadrature (independent of the sampler's table).
TEST_P(FilterSampling, OffsetsFollowTheFilterShape) {
  const PixelFilter filter(GetParam());
  const float r = filter.radius();
  constexpr int kBins = 32, kN = 400000;
  std::vector<double> observed(kBins, 0.0), expected(kBins, 0.0);
  Sampler sampler(1);
  for (int i = 0; i < kN; ++i) {
    sampler.start_pixel_sample(i, 0, 0);
    const glm::vec2 u = sampler.get_2d();
    const float dx = filter.sample(u.x, u.y).x - 0.5f;
    ASSERT_LE(std::abs(dx), r);
    const int bin = std::min(kBins - 1, static_cast<int>((dx + r) / (2 * r) * kBins));
    observed[static_cast<size_t>(bin)] += 1.0;
  }
  double total = 0.0;
  for (int b = 0; b < kBins; ++b) {
    constexpr int kSteps = 200;
    double sum = 0.0;
    for (int k = 0; k < kSteps; ++k) {
      const double x = -r + (b + (k + 0.5) / kSteps) * (2.0 * r / kBins);
      sum += std::abs(filter.evaluate_1d(static_cast<float>(x)));
    }
    expected[static_cast<size_t>(b)] = sum;
    total += sum;
  }
  for (double& e : expected) e *= kN / total;
  // The tabulated density is piecewise constant over 64 cells, so it differs from |f| inside each
  // cell by a second-order amount: 32 bins of 2 cells each average that out well below the test's
  // resolution at this sample count.
  EXPECT_TRUE(chi_square_fits(observed, expected));
}

// Weighted samples estimate the filtered value: sum(w g(x)) / sum(w) -> int f g / int f, here for
// g = x^2 (the filter's variance), worked out by quadrature of the filter itself.
TEST_P(FilterSampling, WeightedSecondMomentMatchesQuadrature) {
  const PixelFilter filter(GetParam());
  const double r = filter.radius();
  double num = 0.0, den = 0.0;
  constexpr int kSteps = 20000;
  for (int k = 0; k < kSteps; ++k) {
    const double x = -r + (k + 0.5) * (2.0 * r / kSteps);
    const double f = filter.evaluate_1d(static_cast<float>(x));
    num += f * x * x;
    den += f;
  }
  const double want = num / den;
  Sampler sampler(2);
  double wsum = 0.0, wg = 0.0;
  constexpr int kN = 400000;
  for (int i = 0; i < kN; ++i) {
    sampler.start_pixel_sample(i, 1, 0);
    const glm::vec2 u = sampler.get_2d();
    const PixelFilter::Sample s = filter.sample(u.x, u.y);
    const double dx = s.x - 0.5;
    wsum += s.weight;
    wg += s.weight * dx * dx;
  }
  EXPECT_NEAR(wg / wsum, want, 0.01 * want);
}

INSTANTIATE_TEST_SUITE_P(Filters, FilterSampling,
                         ::testing::Values(FilterKind::kGaussian, FilterKind::kBlackmanHarris),
                         [](const auto& info) {
                           return info.param == FilterKind::kGaussian ? "gaussian"
                                                                      : "blackman_harris";
                         });

}  // namespace
}  // namespace tritrace
