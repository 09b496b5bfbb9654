// PCG32 and the mixing hash against their published reference outputs, and the float conversion's
// range.
#include "tritrace/math/random.h"

#include <gtest/gtest.h>

#include <cstdint>

namespace tritrace {
namespace {

TEST(Pcg32, MatchesTheReferenceDemoSequence) {
  // O'Neill's pcg32-demo (pcg-c-basic) seeded with pcg32_srandom_r(42, 54) prints these first.
  Pcg32 rng(42, 54);
  for (const uint32_t expected :
       {0xa15c02b7u, 0x7b47f409u, 0xba1d3330u, 0x83d2f293u, 0xbfa4784bu, 0xcbed606eu}) {
    EXPECT_EQ(rng.next_u32(), expected);
  }
}

TEST(Mix64, IsSplitMix64sOutputFunction) {
  // SplitMix64 from state 0 outputs mix64 of 1 and 2 times the golden-ratio increment; its
  // published first outputs (Vigna's splitmix64.c) are these.
  EXPECT_EQ(mix64(0x9e3779b97f4a7c15ull), 0xe220a8397b1dcdafull);
  EXPECT_EQ(mix64(2 * 0x9e3779b97f4a7c15ull), 0x6e789e6aa1b965f4ull);
  // hash_words(0) is therefore that same first output, and hash_words(0, 0) mixes it again.
  EXPECT_EQ(hash_words(0), 0xe220a8397b1dcdafull);
  EXPECT_EQ(hash_words(0, 0), mix64(0xe220a8397b1dcdafull + 0x9e3779b97f4a7c15ull));
}

TEST(HashWords, EveryWordAndItsOrderMatter) {
  EXPECT_NE(hash_words(1, 2, 3), hash_words(1, 3, 2));
  EXPECT_NE(hash_words(1, 2, 3), hash_words(1, 2, 4));
  EXPECT_NE(hash_words(0, 0, 0), hash_words(0, 0));
  EXPECT_EQ(hash_words(5, 6, 7), hash_combine(hash_words(5, 6), 7));
  // Words are mixed before the next is added: moving one unit from a word to the next is a
  // different key (an additive combination without the mix would collide here).
  EXPECT_NE(hash_words(1, 0), hash_words(0, 1));
  EXPECT_NE(hash_words(7, 3, 9), hash_words(7, 4, 8));
}

TEST(UnitFloat, StaysBelowOne) {
  EXPECT_EQ(unit_float(0u), 0.0f);
  EXPECT_EQ(unit_float(0xffffffffu), kOneMinusEpsilon);
  EXPECT_LT(unit_float(0xffffffffu), 1.0f);
  EXPECT_EQ(unit_float(0x80000000u), 0.5f);
  // The low 8 bits do not round the result up.
  EXPECT_EQ(unit_float(0x000000ffu), 0.0f);
  EXPECT_EQ(unit_float(0x000001ffu), 0x1p-24f);
}

}  // namespace
}  // namespace tritrace
