// next_float_up and next_float_down against std::nextafter: on the special values, on every float
// whose bits step by a prime stride through the whole range, and at the ends of each binade.
#include "tritrace/math/next_float.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace tritrace {
namespace {

// (NaN is outside the functions' contract: skipped.)
void expect_as_nextafter(float x) {
  if (std::isnan(x)) return;
  constexpr float inf = std::numeric_limits<float>::infinity();
  const float up = next_float_up(x), down = next_float_down(x);
  EXPECT_EQ(std::bit_cast<uint32_t>(up), std::bit_cast<uint32_t>(std::nextafter(x, inf)))
      << "up from " << x;
  EXPECT_EQ(std::bit_cast<uint32_t>(down), std::bit_cast<uint32_t>(std::nextafter(x, -inf)))
      << "down from " << x;
}

TEST(NextFloat, SpecialValuesAsNextafter) {
  constexpr float inf = std::numeric_limits<float>::infinity();
  for (float x : {0.0f, -0.0f, inf, -inf, std::numeric_limits<float>::max(),
                  -std::numeric_limits<float>::max(), std::numeric_limits<float>::min(),
                  -std::numeric_limits<float>::min(), std::numeric_limits<float>::denorm_min(),
                  -std::numeric_limits<float>::denorm_min(), 1.0f, -1.0f}) {
    expect_as_nextafter(x);
  }
}

TEST(NextFloat, EveryStrideOfTheBitPatternsAsNextafter) {
  int checked = 0;
  for (uint64_t bits = 0; bits <= 0xFFFFFFFFu; bits += 9973) {
    const float x = std::bit_cast<float>(static_cast<uint32_t>(bits));
    if (std::isnan(x)) continue;
    expect_as_nextafter(x);
    // The ends of x's binade too.
    expect_as_nextafter(std::bit_cast<float>(static_cast<uint32_t>(bits) | 0x007FFFFFu));
    expect_as_nextafter(std::bit_cast<float>(static_cast<uint32_t>(bits) & 0xFF800000u));
    ++checked;
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_GT(checked, 400000);
}

}  // namespace
}  // namespace tritrace
