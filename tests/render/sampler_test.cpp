// Sampler, both kinds: the same (seed, pixel, sample index) replays the same numbers, other ones
// give other numbers, and the numbers are uniform and independent across pixels and seeds
// (chi-square against the uniform distribution, whose cell counts are exact). The independent
// sampler's sample indices are independent too; the Sobol sampler's are stratified instead: the
// first 2^m samples of a pixel are a (0, m, 2)-net in every 2-D group, counted box by box, and the
// error of an integral over the pixel falls well below plain Monte Carlo's.
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

class SamplerKinds : public ::testing::TestWithParam<SamplerKind> {};

template <size_t N>
std::array<float, N> draw(Sampler& s) {
  std::array<float, N> out{};
  for (float& v : out) v = s.get_1d();
  return out;
}

std::array<float, 16> sequence(uint64_t seed, int x, int y, uint32_t index,
                               SamplerKind kind = SamplerKind::kSobol) {
  Sampler s(seed, kind);
  s.start_pixel_sample(x, y, index);
  return draw<16>(s);
}

TEST_P(SamplerKinds, SameArgumentsReplayTheSameNumbers) {
  Sampler a(7, GetParam());
  a.start_pixel_sample(3, 5, 11);
  const std::array<float, 64> first = draw<64>(a);
  Sampler b(7, GetParam());
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

TEST_P(SamplerKinds, OtherSeedsPixelsAndIndicesGiveOtherNumbers) {
  const std::array<float, 16> base = sequence(7, 3, 5, 11, GetParam());
  EXPECT_NE(sequence(8, 3, 5, 11, GetParam()), base);
  EXPECT_NE(sequence(7, 4, 5, 11, GetParam()), base);
  EXPECT_NE(sequence(7, 3, 6, 11, GetParam()), base);
  EXPECT_NE(sequence(7, 5, 3, 11, GetParam()), base);  // x and y swapped
  EXPECT_NE(sequence(7, 3, 5, 12, GetParam()), base);
  EXPECT_NE(sequence(0, 0, 0, 0, GetParam()), sequence(0, 0, 0, 1, GetParam()));
  EXPECT_NE(sequence(0, 0, 0, 0, GetParam()), sequence(1, 0, 0, 0, GetParam()));
  // No two of many neighbouring (pixel, index) keys share their first two numbers (48 bits; a
  // collision among 4096 keys has probability about 2^-25).
  std::vector<uint64_t> firsts;
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      for (uint32_t i = 0; i < 16; ++i) {
        const std::array<float, 16> s = sequence(0, x, y, i, GetParam());
        firsts.push_back(static_cast<uint64_t>(s[0] * 0x1p24f) << 24 |
                         static_cast<uint64_t>(s[1] * 0x1p24f));
      }
    }
  }
  std::sort(firsts.begin(), firsts.end());
  EXPECT_EQ(std::adjacent_find(firsts.begin(), firsts.end()), firsts.end());
}

TEST_P(SamplerKinds, SampleIndexDoesNotDependOnEarlierIndices) {
  // Sample i drawn fresh equals sample i drawn after samples 0..i-1 used any number of dimensions.
  Sampler progressive(3, GetParam());
  for (uint32_t i = 0; i < 10; ++i) {
    progressive.start_pixel_sample(17, 9, i);
    EXPECT_EQ(progressive.dimension(), 0u);
    const std::array<float, 16> numbers = draw<16>(progressive);
    EXPECT_EQ(numbers, sequence(3, 17, 9, i, GetParam())) << i;
    for (uint32_t extra = 0; extra < 3 * i; ++extra) (void)progressive.get_1d();
  }
}

// get_2d_groups<N> (SIMD lanes where the build has AVX2) draws exactly what N calls of get_2d
// draw, from any dimension, for many pixels and indices.
template <size_t N>
void expect_groups_match_single_draws(SamplerKind kind) {
  Sampler grouped(13, kind), single(13, kind);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      for (uint32_t i : {0u, 1u, 2u, 77u, 1023u, 0xfffffffeu}) {
        grouped.start_pixel_sample(x * 1000, y, i);
        single.start_pixel_sample(x * 1000, y, i);
        for (int round = 0; round < 5; ++round) {
          (void)grouped.get_1d();  // groups start at odd and even dimensions
          (void)single.get_1d();
          const std::array<glm::vec2, N> u = grouped.get_2d_groups<N>();
          for (size_t g = 0; g < N; ++g) {
            ASSERT_EQ(u[g], single.get_2d()) << "group " << g << " of " << N << ", index " << i;
          }
          ASSERT_EQ(grouped.dimension(), single.dimension());
        }
      }
    }
  }
}

TEST_P(SamplerKinds, GroupsOfTwoDimensionalDrawsEqualSingleDraws) {
  expect_groups_match_single_draws<1>(GetParam());
  expect_groups_match_single_draws<2>(GetParam());
  expect_groups_match_single_draws<3>(GetParam());
  expect_groups_match_single_draws<4>(GetParam());
}

// get_2d_groups_batch<N> (eight samplers to a SIMD operation where the build has AVX2) draws for
// each sampler exactly what N calls of its get_2d draw, for batch sizes that fill the lanes and
// sizes that leave a partial last group of eight, from odd and even dimensions; cells past the
// batch in each row are scratch, the others untouched.
template <size_t N>
void expect_batch_matches_single_draws(SamplerKind kind) {
  for (size_t count : {0u, 1u, 7u, 8u, 9u, 21u}) {
    std::vector<Sampler> batch(count, Sampler(29, kind)), single(count, Sampler(29, kind));
    std::vector<Sampler*> pointers;
    for (size_t j = 0; j < count; ++j) {
      const int x = static_cast<int>(j * 37 % 11), y = static_cast<int>(j / 3);
      const uint32_t index = static_cast<uint32_t>(j * 1000003u);
      batch[j].start_pixel_sample(x, y, index);
      single[j].start_pixel_sample(x, y, index);
      for (size_t skip = 0; skip < j % 3; ++skip) {
        (void)batch[j].get_1d();
        (void)single[j].get_1d();
      }
      pointers.push_back(&batch[j]);
    }
    const size_t stride = 40;
    std::vector<float> out(2 * N * stride, -1.0f);
    Sampler::get_2d_groups_batch<N>(pointers.data(), count, out.data(), stride);
    for (size_t j = 0; j < count; ++j) {
      for (size_t g = 0; g < N; ++g) {
        const glm::vec2 expected = single[j].get_2d();
        ASSERT_EQ(out[2 * g * stride + j], expected.x) << "sampler " << j << " of " << count;
        ASSERT_EQ(out[(2 * g + 1) * stride + j], expected.y) << "sampler " << j << " of " << count;
      }
      ASSERT_EQ(batch[j].dimension(), single[j].dimension());
    }
    for (size_t row = 0; row < 2 * N; ++row) {
      for (size_t j = (count + 7) / 8 * 8; j < stride; ++j) ASSERT_EQ(out[row * stride + j], -1.0f);
    }
  }
}

TEST_P(SamplerKinds, BatchedGroupsEqualSingleDraws) {
  expect_batch_matches_single_draws<1>(GetParam());
  expect_batch_matches_single_draws<3>(GetParam());
  expect_batch_matches_single_draws<4>(GetParam());
}

TEST_P(SamplerKinds, CountsDimensionsAndPixel2dIsTheFirstTwo) {
  Sampler s(1, GetParam());
  s.start_pixel_sample(2, 3, 4);
  const glm::vec2 pixel = s.get_pixel_2d();
  EXPECT_EQ(s.dimension(), 2u);
  (void)s.get_2d();
  (void)s.get_1d();
  EXPECT_EQ(s.dimension(), 5u);
  Sampler again(1, GetParam());
  again.start_pixel_sample(2, 3, 4);
  EXPECT_EQ(again.get_2d(), pixel);
  if (GetParam() == SamplerKind::kIndependent) {
    // One stream: a 2-D draw is two 1-D draws.
    const std::array<float, 16> plain = sequence(1, 2, 3, 4, GetParam());
    EXPECT_EQ(pixel.x, plain[0]);
    EXPECT_EQ(pixel.y, plain[1]);
  }
  EXPECT_EQ(s.seed(), 1u);
  EXPECT_EQ(s.kind(), GetParam());
}

// 64 x 64 pixels, 4 indices each, 64 dimensions per sample: 2^20 numbers.
template <typename Visit>
void for_each_sample(uint64_t seed, SamplerKind kind, Visit visit) {
  Sampler s(seed, kind);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      for (uint32_t i = 0; i < 4; ++i) {
        s.start_pixel_sample(x, y, i);
        visit(s);
      }
    }
  }
}

TEST_P(SamplerKinds, NumbersLieInTheUnitInterval) {
  for_each_sample(5, GetParam(), [](Sampler& s) {
    for (int d = 0; d < 64; ++d) {
      const float u = s.get_1d();
      ASSERT_GE(u, 0.0f);
      ASSERT_LT(u, 1.0f);
    }
  });
}

TEST_P(SamplerKinds, MeanIsOneHalfWithinFourStandardErrors) {
  double total = 0.0;
  int n = 0;
  for_each_sample(6, GetParam(), [&](Sampler& s) {
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

TEST_P(SamplerKinds, OneDimensionalValuesAreUniform) {
  constexpr int kBins = 1000;
  std::vector<double> counts(kBins, 0.0);
  for_each_sample(7, GetParam(), [&](Sampler& s) {
    for (int d = 0; d < 64; ++d) counts[cell_of(s.get_1d(), kBins)] += 1.0;
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(kBins, 1 << 20)));
}

TEST_P(SamplerKinds, PairsOfDimensionsAreUniformOverTheSquare) {
  constexpr int kBins = 32;
  std::vector<double> counts(kBins * kBins, 0.0);
  for_each_sample(8, GetParam(), [&](Sampler& s) {
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

float first_number(uint64_t seed, int x, int y, uint32_t index,
                   SamplerKind kind = SamplerKind::kSobol) {
  Sampler s(seed, kind);
  s.start_pixel_sample(x, y, index);
  return s.get_1d();
}

TEST_P(SamplerKinds, NeighbouringPixelsAreIndependent) {
  const std::vector<double> counts = neighbour_pairs([&](int x, int y) {
    return std::pair{first_number(0, x, y, 0, GetParam()),
                     first_number(0, x + 1, y, 0, GetParam())};
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(counts.size(), 1 << 20)));
}

// Plain Monte Carlo only: the Sobol sampler's indices of one pixel are stratified, not independent.
TEST(IndependentSampler, NeighbouringSampleIndicesAreIndependent) {
  const std::vector<double> counts = neighbour_pairs([](int x, int y) {
    const auto i = static_cast<uint32_t>(x);
    return std::pair{first_number(1, 0, y, i, SamplerKind::kIndependent),
                     first_number(1, 0, y, i + 1, SamplerKind::kIndependent)};
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(counts.size(), 1 << 20)));
}

TEST_P(SamplerKinds, NeighbouringSeedsAreIndependent) {
  const std::vector<double> counts = neighbour_pairs([&](int x, int y) {
    const auto seed = static_cast<uint64_t>(x);
    return std::pair{first_number(seed, y, 0, 0, GetParam()),
                     first_number(seed + 1, y, 0, 0, GetParam())};
  });
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(counts.size(), 1 << 20)));
}

INSTANTIATE_TEST_SUITE_P(Kinds, SamplerKinds,
                         ::testing::Values(SamplerKind::kSobol, SamplerKind::kIndependent),
                         [](const auto& info) { return std::string(sampler_name(info.param)); });

TEST(SamplerKind, NamesRoundTrip) {
  for (SamplerKind k : {SamplerKind::kSobol, SamplerKind::kIndependent}) {
    EXPECT_EQ(parse_sampler(sampler_name(k)), k);
  }
  EXPECT_FALSE(parse_sampler("halton"));
  EXPECT_EQ(Sampler().kind(), SamplerKind::kSobol);  // the default
}

// The 32-bit fraction a number came from (numbers are multiples of 2^-24).
uint32_t fraction_bits(float u) {
  return static_cast<uint32_t>(u * 0x1p24f) << 8;
}

// Whether 2^m points are a (0, m, 2)-net: each box of every 2^a x 2^(m-a) dyadic grid holds one.
bool is_net(const std::vector<glm::vec2>& points, int m) {
  for (int a = 0; a <= m; ++a) {
    const int b = m - a;
    std::vector<int> count(points.size(), 0);
    for (const glm::vec2 p : points) {
      const uint32_t cx = a == 0 ? 0 : fraction_bits(p.x) >> (32 - a);
      const uint32_t cy = b == 0 ? 0 : fraction_bits(p.y) >> (32 - b);
      if (++count[(cx << b) | cy] > 1) return false;
    }
  }
  return true;
}

// The samples [first, first + 2^m) of a pixel, for first a multiple of 2^m (so any power-of-two
// spp, and the aligned sample ranges a split render draws): the pixel position, a later 2-D group
// and a 1-D group are each stratified as well as 2^m points can be.
TEST(SobolSampler, AlignedBlocksOfAPixelsSamplesAreStratified) {
  Sampler s(42, SamplerKind::kSobol);
  for (int m = 0; m <= 10; ++m) {
    const uint32_t n = 1u << m;
    for (uint32_t first : {0u, n, 5 * n}) {
      for (const auto& [x, y] : {std::pair{0, 0}, std::pair{17, 3}, std::pair{1023, 511}}) {
        std::vector<glm::vec2> pixel, later;
        std::vector<int> strata(n, 0);
        for (uint32_t i = first; i < first + n; ++i) {
          s.start_pixel_sample(x, y, i);
          pixel.push_back(s.get_pixel_2d());
          (void)s.get_1d();
          (void)s.get_2d();
          later.push_back(s.get_2d());
          const float u = s.get_1d();
          ++strata[m == 0 ? 0 : fraction_bits(u) >> (32 - m)];
        }
        EXPECT_TRUE(is_net(pixel, m)) << "m " << m << " first " << first << " pixel " << x;
        EXPECT_TRUE(is_net(later, m)) << "m " << m << " first " << first << " pixel " << x;
        EXPECT_EQ(std::count(strata.begin(), strata.end(), 1), static_cast<long>(n))
            << "m " << m << " first " << first << " pixel " << x;
      }
    }
  }
}

// Different groups of one sample are independent: the first number of the group at dimension 2
// against the first of the group at dimension 4, over many pixels and samples, is uniform over
// the square (a sampler that reused one index order for every group would put them on a line).
TEST(SobolSampler, GroupsOfASampleAreIndependent) {
  constexpr int kBins = 32;
  std::vector<double> counts(kBins * kBins, 0.0);
  Sampler s(9, SamplerKind::kSobol);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      for (uint32_t i = 0; i < 64; ++i) {
        s.start_pixel_sample(x, y, i);
        (void)s.get_pixel_2d();
        const float a = s.get_2d().x;
        const float b = s.get_2d().y;
        counts[cell_of(a, kBins) * kBins + cell_of(b, kBins)] += 1.0;
      }
    }
  }
  EXPECT_TRUE(chi_square_fits(counts, uniform_expected(counts.size(), 1 << 18)));
}

// What stratification is for: the fraction of a pixel covered by a disk (the kind of edge a light
// or an object makes) estimated from 256 samples per pixel, for 512 pixels with differently
// placed disks. Both samplers are unbiased (the mean error is within 4 standard errors of 0); the
// Sobol sampler's RMS error is well under half of plain Monte Carlo's (asymptotically N^-3/4
// against N^-1/2 for such an edge). The exact coverage comes from a fine grid in double.
TEST(SobolSampler, StratificationLowersTheErrorOfAPixelIntegral) {
  constexpr int kPixels = 512;
  constexpr uint32_t kSpp = 256;
  double sq_error[2] = {0.0, 0.0}, sum_error[2] = {0.0, 0.0};
  for (int p = 0; p < kPixels; ++p) {
    Pcg32 rng(static_cast<uint64_t>(p), 77);
    const double cx = rng.next_float() * 2.0 - 0.5, cy = rng.next_float() * 2.0 - 0.5;
    const double r2 = 0.2 + 0.5 * rng.next_float();
    const auto inside = [&](double x, double y) {
      return (x - cx) * (x - cx) + (y - cy) * (y - cy) < r2;
    };
    constexpr int kGrid = 1024;
    int covered = 0;
    for (int j = 0; j < kGrid; ++j) {
      for (int i = 0; i < kGrid; ++i) covered += inside((i + 0.5) / kGrid, (j + 0.5) / kGrid);
    }
    const double exact = static_cast<double>(covered) / (kGrid * kGrid);
    for (int k = 0; k < 2; ++k) {
      Sampler s(3, k == 0 ? SamplerKind::kSobol : SamplerKind::kIndependent);
      int hits = 0;
      for (uint32_t i = 0; i < kSpp; ++i) {
        s.start_pixel_sample(p, 0, i);
        const glm::vec2 u = s.get_pixel_2d();
        hits += inside(u.x, u.y);
      }
      const double error = static_cast<double>(hits) / kSpp - exact;
      sq_error[k] += error * error;
      sum_error[k] += error;
    }
  }
  const double rms_sobol = std::sqrt(sq_error[0] / kPixels);
  const double rms_independent = std::sqrt(sq_error[1] / kPixels);
  EXPECT_LT(rms_sobol, 0.5 * rms_independent) << rms_sobol << " vs " << rms_independent;
  for (int k = 0; k < 2; ++k) {
    const double rms = std::sqrt(sq_error[k] / kPixels);
    EXPECT_LT(std::abs(sum_error[k] / kPixels), 4.0 * rms / std::sqrt(kPixels)) << k;
  }
}

}  // namespace
}  // namespace tritrace
