// The Sobol points and Owen scrambling behind the stratified sampler, against independent oracles:
// bit reversal by a loop over bits, dimension 1 by the classic direction-number recurrence, the
// (0, m, 2)-net property counted box by box, and the nested structure of an Owen scramble.
#include "tritrace/math/sobol.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "../math/chi_square.h"
#include "tritrace/math/random.h"

namespace tritrace {
namespace {

uint32_t reverse_by_loop(uint32_t x) {
  uint32_t r = 0;
  for (int i = 0; i < 32; ++i) r |= ((x >> i) & 1u) << (31 - i);
  return r;
}

TEST(Sobol, ReverseBitsMirrorsEveryBit) {
  Pcg32 rng(1, 2);
  for (uint32_t x : {0u, 1u, 0x80000000u, 0xffffffffu, 0x12345678u}) {
    EXPECT_EQ(reverse_bits(x), reverse_by_loop(x));
  }
  for (int i = 0; i < 100000; ++i) {
    const uint32_t x = rng.next_u32();
    ASSERT_EQ(reverse_bits(x), reverse_by_loop(x)) << x;
  }
}

// Dimension 1 from its direction numbers as Joe and Kuo tabulate them for the polynomial x + 1
// (m_k = 1 for every k): v_0 = 1/2 and v_k = v_{k-1} xor v_{k-1} / 2, each index bit k adding v_k.
uint32_t sobol1_by_direction_numbers(uint32_t index) {
  uint32_t v = 0x80000000u, result = 0;
  for (int k = 0; k < 32; ++k, v ^= v >> 1) {
    if ((index >> k) & 1u) result ^= v;
  }
  return result;
}

TEST(Sobol, Dimension1MatchesTheDirectionNumbers) {
  for (uint32_t i = 0; i < (1u << 16); ++i) {
    ASSERT_EQ(sobol_dimension1(i), sobol1_by_direction_numbers(i)) << i;
  }
  Pcg32 rng(3, 4);
  for (int n = 0; n < 100000; ++n) {
    const uint32_t i = rng.next_u32();
    ASSERT_EQ(sobol_dimension1(i), sobol1_by_direction_numbers(i)) << i;
  }
  // The first points, by hand: 0, 1/2, 3/4, 1/4.
  EXPECT_EQ(sobol_dimension1(0), 0u);
  EXPECT_EQ(sobol_dimension1(1), 0x80000000u);
  EXPECT_EQ(sobol_dimension1(2), 0xc0000000u);
  EXPECT_EQ(sobol_dimension1(3), 0x40000000u);
  EXPECT_EQ(sobol_dimension0(1), 0x80000000u);
  EXPECT_EQ(sobol_dimension0(2), 0x40000000u);
}

// True when the 2^m points form a (0, m, 2)-net: for every split of m into a + b, each of the 2^a
// x 2^b boxes of the unit square's dyadic grid holds exactly one point.
::testing::AssertionResult is_02_net(const std::vector<std::array<uint32_t, 2>>& points, int m) {
  if (points.size() != (size_t{1} << m)) return ::testing::AssertionFailure() << "wrong size";
  for (int a = 0; a <= m; ++a) {
    const int b = m - a;
    std::vector<int> count(points.size(), 0);
    for (const auto& p : points) {
      const uint64_t cx = a == 0 ? 0 : p[0] >> (32 - a);
      const uint64_t cy = b == 0 ? 0 : p[1] >> (32 - b);
      ++count[(cx << b) | cy];
    }
    for (size_t c = 0; c < count.size(); ++c) {
      if (count[c] != 1) {
        return ::testing::AssertionFailure() << "box " << c << " of the " << (1 << a) << " x "
                                             << (1 << b) << " grid holds " << count[c] << " points";
      }
    }
  }
  return ::testing::AssertionSuccess();
}

TEST(Sobol, AlignedBlocksOfPointsAreNets) {
  for (int m = 0; m <= 12; ++m) {
    for (uint32_t block : {0u, 1u, 7u, 1000u}) {
      std::vector<std::array<uint32_t, 2>> points;
      for (uint32_t i = 0; i < (1u << m); ++i) {
        const uint32_t index = (block << m) + i;
        points.push_back({sobol_dimension0(index), sobol_dimension1(index)});
      }
      EXPECT_TRUE(is_02_net(points, m)) << "m " << m << ", block " << block;
    }
  }
}

TEST(Sobol, OwenScramblingKeepsNetsAndShufflesBlocks) {
  Pcg32 rng(5, 6);
  for (int m = 1; m <= 10; ++m) {
    for (int trial = 0; trial < 8; ++trial) {
      const uint32_t shuffle = rng.next_u32(), sx = rng.next_u32(), sy = rng.next_u32();
      std::vector<std::array<uint32_t, 2>> points;
      std::vector<uint32_t> shuffled;
      for (uint32_t i = 0; i < (1u << m); ++i) {
        const uint32_t index = owen_scramble(i, shuffle);
        shuffled.push_back(index);
        points.push_back({owen_scramble(sobol_dimension0(index), sx),
                          owen_scramble(sobol_dimension1(index), sy)});
      }
      // The scrambled indices of 0..2^m-1 are one aligned block of 2^m indices, in some order.
      std::vector<bool> seen(size_t{1} << m, false);
      for (uint32_t index : shuffled) {
        EXPECT_EQ(index >> m, shuffled[0] >> m);
        seen[index & ((1u << m) - 1)] = true;
      }
      EXPECT_EQ(std::count(seen.begin(), seen.end(), true), 1 << m);
      EXPECT_TRUE(is_02_net(points, m)) << "m " << m << ", trial " << trial;
    }
  }
}

// An Owen scramble flips each digit by a function of the digits before it: two fractions that share
// their first j digits still share them, and their (j+1)-th digits still differ.
TEST(Sobol, OwenScrambleIsNested) {
  Pcg32 rng(7, 8);
  for (int n = 0; n < 200000; ++n) {
    const uint32_t seed = rng.next_u32(), x = rng.next_u32(), y = rng.next_u32();
    const int shared = x == y ? 32 : __builtin_clz(x ^ y);
    const uint32_t sx = owen_scramble(x, seed), sy = owen_scramble(y, seed);
    ASSERT_EQ(sx == sy ? 32 : __builtin_clz(sx ^ sy), shared) << x << " " << y << " " << seed;
  }
}

// Over random seeds, a scrambled fraction is uniform on [0, 1) whatever the fraction: chi-square of
// the top 10 bits for a few fixed fractions, pooled.
TEST(Sobol, ScrambledFractionsAreUniformOverSeeds) {
  constexpr int kBins = 1024, kPerValue = 1 << 17;
  std::vector<double> counts(kBins, 0.0);
  Pcg32 rng(9, 10);
  const std::array<uint32_t, 4> values = {0u, 0x80000000u, 0x12345678u, 0xffffffffu};
  for (uint32_t v : values) {
    for (int n = 0; n < kPerValue; ++n) counts[owen_scramble(v, rng.next_u32()) >> 22] += 1.0;
  }
  const std::vector<double> expected(kBins, double(kPerValue) * values.size() / kBins);
  EXPECT_TRUE(chi_square_fits(counts, expected));
}

}  // namespace
}  // namespace tritrace
