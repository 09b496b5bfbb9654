// The film and its pixel filters: sums and resolution, the box filter's sample positions, and the
// Gaussian and Blackman-Harris filters' sampling against their own shapes (chi-square of the
// positions, and weighted moments against quadrature of the filter).
#include "tritrace/render/film.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "../math/chi_square.h"
#include "tritrace/error.h"
#include "tritrace/math/random.h"
#include "tritrace/render/sample_blocks.h"
#include "tritrace/render/sampler.h"

namespace tritrace {
namespace {

TEST(Film, ResolvesWeightedMeans) {
  Film film(2, 1, AovSet{.albedo = true, .depth = true});
  film.set_layout(0, 2, {});  // one partial block
  film.sums(0)[0] = glm::vec4(1.0f + 3.0f * 4.0f, 1.0f + 3.0f * 4.0f, 13.0f, 4.0f);
  film.aov_sums(0)[0] = {.albedo = glm::vec3(0.5f + 3.0f), .depth = 2.0f + 12.0f};
  const Image image = film.resolve();
  EXPECT_EQ(image.at(0, 0), glm::vec3(13.0f / 4.0f));
  EXPECT_EQ(image.at(1, 0), glm::vec3(0.0f)) << "no sample: black, not NaN";
  EXPECT_EQ(film.resolve_albedo().at(0, 0), glm::vec3(3.5f / 4.0f));
  EXPECT_EQ(film.resolve_depth().at(0, 0), glm::vec3(14.0f / 4.0f));
  EXPECT_TRUE(film.resolve_normal().pixels().empty()) << "not kept";
}

// Four unit samples per pixel, R: 1, 3, 2, 6 (even half 1, 2: mean 1.5; odd 3, 6: mean 4.5), G:
// 5 each, B: 0, 0, 4, 0. The variance of the mean of two independent halves' mean is a quarter of
// their squared difference: (1.5 - 4.5)^2 / 4 = 2.25, 0, (2 - 0)^2 / 4 = 1. Three samples 1, 4,
// 3 (even 1, 3: mean 2; odd 4): sigma^2 (1/2 + 1) = (2 - 4)^2 estimates sigma^2 = 8/3, and the
// mean of three has sigma^2 / 3 = 8/9. One sample: no odd half, no estimate (0).
TEST(Film, VarianceFromTheHalfBuffers) {
  Film film(3, 1, AovSet{.variance = true});
  film.set_layout(0, 4, {});
  film.sums(0)[0] = glm::vec4(12.0f, 20.0f, 4.0f, 4.0f);
  film.aov_sums(0)[0].even = glm::vec4(3.0f, 10.0f, 4.0f, 2.0f);
  film.sums(0)[1] = glm::vec4(8.0f, 0.0f, 0.0f, 3.0f);
  film.aov_sums(0)[1].even = glm::vec4(4.0f, 0.0f, 0.0f, 2.0f);
  film.sums(0)[2] = glm::vec4(7.0f, 7.0f, 7.0f, 1.0f);
  film.aov_sums(0)[2].even = glm::vec4(7.0f, 7.0f, 7.0f, 1.0f);
  const Image v = film.resolve_variance();
  EXPECT_EQ(v.at(0, 0), glm::vec3(2.25f, 0.0f, 1.0f));
  EXPECT_NEAR(v.at(1, 0).x, 8.0f / 9.0f, 1e-6f);
  EXPECT_EQ(v.at(2, 0), glm::vec3(0.0f));
  EXPECT_TRUE(film.resolve_albedo().pixels().empty()) << "not kept";
  const AovImages all = film.resolve_aovs();
  EXPECT_EQ(all.variance.at(0, 0), v.at(0, 0));
  EXPECT_TRUE(all.depth.pixels().empty());
  EXPECT_TRUE(Film(1, 1).resolve_variance().pixels().empty()) << "not kept";
}

TEST(Film, OneUnitSampleResolvesToItselfBitForBit) {
  Film film(1, 1);
  film.set_layout(0, 1, {});
  const glm::vec3 v(0.1f, 1.0f / 3.0f, 7e-30f);
  film.sums(0)[0] = glm::vec4(v, 1.0f);
  EXPECT_EQ(film.resolve().at(0, 0), v);
}

TEST(Film, LayersAreAddedFromTheRight) {
  // 3 complete blocks and a partial one: nodes (1, 0) and (0, 2), then the partial block 3.
  Film film(1, 1);
  film.set_layout(0, 28, {{1, 0}, {0, 2}});
  ASSERT_EQ(film.layer_count(), 3u);
  // Values chosen so that the association matters in float: 1 + (2^-24 + 2^-24) = 1 + 2^-23,
  // while (1 + 2^-24) + 2^-24 rounds to 1 twice.
  const float tiny = std::ldexp(1.0f, -24);
  film.sums(0)[0] = glm::vec4(1.0f, 0.0f, 0.0f, 1.0f);
  film.sums(1)[0] = glm::vec4(tiny, 0.0f, 0.0f, 0.0f);
  film.sums(2)[0] = glm::vec4(tiny, 0.0f, 0.0f, 0.0f);
  EXPECT_EQ(film.radiance_sum(0, 0).x, 1.0f + std::ldexp(1.0f, -23));
  EXPECT_NE((1.0f + tiny) + tiny, 1.0f + std::ldexp(1.0f, -23)) << "the test's premise";
}

TEST(Film, LayoutMustBeTheBlockCountersNodes) {
  Film film(1, 1);
  EXPECT_THROW(film.set_layout(4, 16, {}), Error) << "not at a multiple of 8";
  EXPECT_THROW(film.set_layout(0, 24, {{0, 0}, {0, 1}, {0, 2}}), Error) << "blocks 0, 1 pair";
  EXPECT_NO_THROW(film.set_layout(0, 24, {{1, 0}, {0, 2}}));
  EXPECT_NO_THROW(film.set_layout(8, 40, {{0, 1}, {1, 1}, {0, 4}}));
}

// The counter's nodes for blocks [a, b), by an independent rule: the canonical decomposition of
// [a, b) into maximal aligned power-of-two runs that a segment tree would give, where a run is
// combined with a left sibling only if that sibling lies inside [a, b) too.
std::vector<BlockNode> decomposition(uint64_t a, uint64_t b) {
  std::vector<BlockNode> nodes;
  uint64_t p = a;
  while (p < b) {
    uint32_t level = 0;
    // Grow while the parent starts at p (p aligned to it) and ends within b.
    while ((p % (uint64_t{2} << level)) == 0 && p + (uint64_t{2} << level) <= b) ++level;
    nodes.push_back({level, p >> level});
    p += uint64_t{1} << level;
  }
  // Pairs straddling two of those runs never form: a run starting at p is aligned to its size,
  // and everything left of it is at least as large, so the list is already final.
  return nodes;
}

TEST(BlockCounter, LeavesTheAlignedRunsOfTheRange) {
  for (uint64_t a = 0; a < 40; ++a) {
    for (uint64_t b = a; b < 80; ++b) {
      BlockCounter one_by_one;
      for (uint64_t k = a; k < b; ++k) one_by_one.push({0, k});
      const std::vector<BlockNode> want = decomposition(a, b);
      ASSERT_TRUE(std::equal(want.begin(), want.end(), one_by_one.nodes().begin(),
                             one_by_one.nodes().end()))
          << "[" << a << ", " << b << ")";
      BlockCounter runs;
      runs.push_blocks(a, b);
      ASSERT_TRUE(std::equal(want.begin(), want.end(), runs.nodes().begin(), runs.nodes().end()))
          << "[" << a << ", " << b << ")";
    }
  }
}

// The sum of blocks [0, n) by the documented rule written as a recursion over the tree: node
// (L, i) = node(L-1, 2i) + node(L-1, 2i+1); the nodes of n's binary digits are added from the
// right. Exact integers cannot tell orders apart, so the blocks hold floats whose sums round.
float tree_sum(const std::vector<float>& blocks, uint32_t level, uint64_t index) {
  if (level == 0) return blocks[index];
  return tree_sum(blocks, level - 1, 2 * index) + tree_sum(blocks, level - 1, 2 * index + 1);
}
float documented_sum(const std::vector<float>& blocks) {
  std::vector<float> digits;
  uint64_t p = 0;
  for (int level = 62; level >= 0; --level) {
    if (blocks.size() & (uint64_t{1} << level)) {
      digits.push_back(tree_sum(blocks, static_cast<uint32_t>(level), p >> level));
      p += uint64_t{1} << level;
    }
  }
  float sum = digits.back();
  for (size_t k = digits.size() - 1; k-- > 0;) sum = digits[k] + sum;
  return sum;
}

TEST(BlockCounter, AnySplitMergesToTheSameBits) {
  Pcg32 rng(7, 3);
  for (size_t n = 1; n <= 70; ++n) {
    std::vector<float> blocks(n);
    for (float& b : blocks)
      b = std::ldexp(rng.next_float() + 0.5f, static_cast<int>(rng.next_u32() % 40) - 20);
    const float want = documented_sum(blocks);
    // Split [0, n) at every pair of points: three parts, each counted on its own, then merged by
    // pushing the parts' nodes in order.
    for (size_t s1 = 0; s1 <= n; ++s1) {
      for (size_t s2 = s1; s2 <= n; ++s2) {
        BlockCounter merged;
        std::vector<float> merged_values;
        for (auto [a, b] : {std::pair{size_t{0}, s1}, std::pair{s1, s2}, std::pair{s2, n}}) {
          BlockCounter part;
          std::vector<float> values;
          for (size_t k = a; k < b; ++k) {
            values.push_back(blocks[k]);
            const int m = part.push({0, k});
            values.resize(merge_last(values.data(), values.size(), m));
          }
          for (size_t j = 0; j < part.size(); ++j) {
            merged_values.push_back(values[j]);
            const int m = merged.push(part.nodes()[j]);
            merged_values.resize(merge_last(merged_values.data(), merged_values.size(), m));
          }
        }
        ASSERT_EQ(fold_from_right(merged_values.data(), merged_values.size()), want)
            << "n " << n << " split " << s1 << ", " << s2;
      }
    }
  }
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
