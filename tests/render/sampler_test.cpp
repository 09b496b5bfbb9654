// Sampler: the same (seed, pixel, sample index) replays the same numbers, other ones give other
// numbers, and the numbers are uniform and independent across dimensions, pixels and indices
// (chi-square against the uniform distribution, whose cell counts are exact).
#include "tritrace/render/sampler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "../math/chi_square.h"

namespace tritrace {
namespace {

template <size_t N>
std::array<float, N> draw(Sampler& s) {
  std::array<float, N> out{};
  for (float& v : out) v = s.get_1d();
  return out;
}

std::array<float, 16> sequence(uint64_t seed, int x, int y, uint32_t index) {
  Sampler s(seed);
  s.start_pixel_sample(x, y, index);
  return draw<16>(s);
}

TEST(Sampler, SameArgumentsReplayTheSameNumbers) {
  Sampler a(7);
  a.start_pixel_sample(3, 5, 11);
  const std::array<float, 64> first = draw<64>(a);
  Sampler b(7);
  b.start_pixel_sample(100, 200, 0);
  (void)draw<10>(b);
  b.start_pixel_sample(3, 5, 11);
  EXPECT_EQ(draw<64>(b), first);
  a.start_pixel_sample(3, 5, 11);
  EXPECT_EQ(draw<64>(a), first);
  // A copy continues exactly where the original is.
  a.start_pixel_sample(3, 5, 11);
  (void)a.get_2d();
  Sampler c = a;
  EXPECT_EQ(draw<8>(c), draw<8>(a));
}

TEST(Sampler, OtherSeedsPixelsAndIndicesGiveOtherNumbers) {
  const std::array<float, 16> base = sequence(7, 3, 5, 11);
  EXPECT_NE(sequence(8, 3, 5, 11), base);
  EXPECT_NE(sequence(7, 4, 5, 11), base);
  EXPECT_NE(sequence(7, 3, 6, 11), base);
  EXPECT_NE(sequence(7, 5, 3, 11), base);  // x and y swapped
  EXPECT_NE(sequence(7, 3, 5, 12), base);
  EXPECT_NE(sequence(0, 0, 0, 0), sequence(0, 0, 0, 1));
  EXPECT_NE(sequence(0, 0, 0, 0), sequence(1, 0, 0, 0));
  // No two of many neighbouring (pixel, index) keys share their first two numbers (48 bits; a
  // collision among 4096 keys has probability about 2^-25).
  std::vector<uint64_t> firsts;
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      for (uint32_t i = 0; i < 16; ++i) {
        const std::array<float, 16> s = sequence(0, x, y, i);
        firsts.push_back(static_cast<uint64_t>(s[0] * 0x1p24f) << 24 |
                         static_cast<uint64_t>(s[1] * 0x1p24f));
      }
    }
  }
  std::sort(firsts.begin(), firsts.end());
  EXPECT_EQ(std::adjacent_find(firsts.begin(), firsts.end()), firsts.end());
}

TEST(Sampler, SampleIndexDoesNotDependOnEarlierIndices) {
  // Sample i drawn fresh equals sample i drawn after samples 0..i-1 used any number of dimensions.
  Sampler progressive(3);
  for (uint32_t i = 0; i < 10; ++i) {
    progressive.start_pixel_sample(17, 9, i);
    EXPECT_EQ(progressive.dimension(), 0u);
    const std::array<float, 16> numbers = draw<16>(progressive);
    EXPECT_EQ(numbers, sequence(3, 17, 9, i)) << i;
    for (uint32_t extra = 0; extra < 3 * i; ++extra) (void)progressive.get_1d();
  }
}

TEST(Sampler, CountsDimensionsAndPixel2dIsTheFirstTwo) {
  Sampler s(1);
  s.start_pixel_sample(2, 3, 4);
  const glm::vec2 pixel = s.get_pixel_2d();
  EXPECT_EQ(s.dimension(), 2u);
  (void)s.get_2d();
  (void)s.get_1d();
  EXPECT_EQ(s.dimension(), 5u);
  const std::array<float, 16> plain = sequence(1, 2, 3, 4);
  EXPECT_EQ(pixel.x, plain[0]);
  EXPECT_EQ(pixel.y, plain[1]);
  EXPECT_EQ(s.seed(), 1u);
}

// 64 x 64 pixels, 4 indices each, 64 dimensions per sample: 2^20 numbers.
template <typename Visit>
void for_each_sample(uint64_t seed, Visit visit) {
  Sampler s(seed);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      for (uint32_t i = 0; i < 4; ++i) {
        s.start_pixel_sample(x, y, i);
        visit(s);
      }
    }
  }
}

TEST(Sampler, NumbersLieInTheUnitInterval) {
  for_each_sample(5, [](Sampler& s) {
    for (int d = 0; d < 64; ++d) {
      const float u = s.get_1d();
      ASSERT_GE(u, 0.0f);
      ASSERT_LT(u, 1.0f);
    }
  });
}

TEST(Sampler, MeanIsOneHalfWithinFourStandardErrors) {
  double total = 0.0;
  int n = 0;
  for_each_sample(6, [&](Sampler& s) {
    for (int d = 0; d < 64; ++d, ++n) total += s.get_1d();
  });
  ASSERT_EQ(n, 1 << 20);
  // The variance of U(0, 1) is 1/12; the numbers' mean is 1/2 - 2^-25 (multiples of 2^-24).
  const double standard_error = std::sqrt(1.0 / 12.0 / n);
  EXPECT_NEAR(total / n, 0.5 - 0x1p-25, 4.0 * standard_error);
}

std::vector<double> uniform_expected(size_t cells, double samples) {
  return std::vector<double>(cells, samples / static_cast<double>(cells));
}

int cell_of(float u, int bins) {
  return static_cast<int>(u * static_cast<float>(bins));
}

TEST(Sampler, OneDimensionalValuesAreUniform) {
  constexpr int kBins = 1000;
  std::vector<double> counts(kBins, 0.0);
  for_each_sample(7, [&](Sampler& s) {
    for (int d = 0; d < 64; ++d) counts[cell_of(s.get_1d(), kBins)] += 1.0;
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(kBins, 1 << 20)));
}

TEST(Sampler, PairsOfDimensionsAreUniformOverTheSquare) {
  constexpr int kBins = 32;
  std::vector<double> counts(kBins * kBins, 0.0);
  for_each_sample(8, [&](Sampler& s) {
    for (int d = 0; d < 32; ++d) {
      const glm::vec2 u = s.get_2d();
      counts[cell_of(u.x, kBins) * kBins + cell_of(u.y, kBins)] += 1.0;
    }
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(kBins * kBins, 1 << 19)));
}

// Independence between streams: the first number of one stream against the first number of a
// neighbouring one (the next pixel, the next sample index, the next seed) is uniform over the
// square. A weak hash shows up exactly here: neighbouring keys differ in few bits.
template <typename Neighbour>
std::vector<double> neighbour_pairs(Neighbour neighbour) {
  constexpr int kBins = 32;
  std::vector<double> counts(kBins * kBins, 0.0);
  for (int y = 0; y < 1024; ++y) {
    for (int x = 0; x < 1024; ++x) {
      const auto [a, b] = neighbour(x, y);
      counts[cell_of(a, kBins) * kBins + cell_of(b, kBins)] += 1.0;
    }
  }
  return counts;
}

float first_number(uint64_t seed, int x, int y, uint32_t index) {
  Sampler s(seed);
  s.start_pixel_sample(x, y, index);
  return s.get_1d();
}

TEST(Sampler, NeighbouringPixelsAreIndependent) {
  const std::vector<double> counts = neighbour_pairs([](int x, int y) {
    return std::pair{first_number(0, x, y, 0), first_number(0, x + 1, y, 0)};
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(counts.size(), 1 << 20)));
}

TEST(Sampler, NeighbouringSampleIndicesAreIndependent) {
  const std::vector<double> counts = neighbour_pairs([](int x, int y) {
    const auto i = static_cast<uint32_t>(x);
    return std::pair{first_number(1, 0, y, i), first_number(1, 0, y, i + 1)};
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(counts.size(), 1 << 20)));
}

TEST(Sampler, NeighbouringSeedsAreIndependent) {
  const std::vector<double> counts = neighbour_pairs([](int x, int y) {
    const auto seed = static_cast<uint64_t>(x);
    return std::pair{first_number(seed, y, 0, 0), first_number(seed + 1, y, 0, 0)};
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(counts.size(), 1 << 20)));
}

}  // namespace
}  // namespace tritrace
