// offset_ray_origin, by hand: each coordinate moves by int_scale * n ULPs of itself (counted on the
// float's bits), or by float_scale * extent * n when that is farther, always towards n.
#include "tritrace/math/offset_ray.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "tritrace/math/random.h"

namespace tritrace {
namespace {

// The defaults: 4 ULPs per unit of normal, and 2^-16 of the extent.
constexpr RayOffsetParams kDefault{};

TEST(OffsetRayOrigin, MovesFourUlpsAlongAUnitNormalAwayFromZero) {
  // 1.0f's ULP above it is 2^-23; 1e4's is 2^-10 (8192 <= 1e4 < 16384).
  const glm::vec3 p = offset_ray_origin({1.0f, 1e4f, 3.0f}, {1.0f, 0.0f, 0.0f}, 0.0f);
  EXPECT_EQ(p.x, 1.0f + 4.0f * 0x1p-23f);
  EXPECT_EQ(p.y, 1e4f);
  EXPECT_EQ(p.z, 3.0f);
  EXPECT_EQ(offset_ray_origin({0.0f, 1e4f, 0.0f}, {0.0f, 1.0f, 0.0f}, 0.0f).y,
            1e4f + 4.0f * 0x1p-10f);
}

TEST(OffsetRayOrigin, NegativeCoordinatesAndNormalsMoveTheRightWay) {
  // -1 towards +x: its magnitude shrinks, by the ULPs below 1 (2^-24 each).
  EXPECT_EQ(offset_ray_origin({-1.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, 0.0f).x,
            -1.0f + 4.0f * 0x1p-24f);
  // 1 towards -x, -1 towards -x.
  EXPECT_EQ(offset_ray_origin({1.0f, 0.0f, 0.0f}, {-1.0f, 0.0f, 0.0f}, 0.0f).x,
            1.0f - 4.0f * 0x1p-24f);
  EXPECT_EQ(offset_ray_origin({-1.0f, 0.0f, 0.0f}, {-1.0f, 0.0f, 0.0f}, 0.0f).x,
            -1.0f - 4.0f * 0x1p-23f);
}

TEST(OffsetRayOrigin, TiltedNormalMovesEachCoordinateByItsShare) {
  // n = (0.6, 0, -0.8): int(4 * 0.6) = 2 ULPs up in x, int(4 * 0.8) = 3 ULPs down in z.
  const glm::vec3 p = offset_ray_origin({2.0f, 5.0f, 2.0f}, {0.6f, 0.0f, -0.8f}, 0.0f);
  EXPECT_EQ(p.x, 2.0f + 2.0f * 0x1p-22f);
  EXPECT_EQ(p.y, 5.0f);
  EXPECT_EQ(p.z, 2.0f - 3.0f * 0x1p-23f);
}

TEST(OffsetRayOrigin, ExtentTermRulesNearZeroAndForSmallCoordinates) {
  // At 0 the ULP step is a denormal; the extent term moves it by 2^-16 * extent.
  const glm::vec3 at_zero = offset_ray_origin({0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 2.0f);
  EXPECT_EQ(at_zero.z, 2.0f * 0x1p-16f);
  const glm::vec3 down = offset_ray_origin({0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -1.0f}, 2.0f);
  EXPECT_EQ(down.z, -2.0f * 0x1p-16f);
  EXPECT_FALSE(std::isnan(down.z));
  // 0.1 with extent 1: 4 ULPs of 0.1 (2^-27 each) are 3e-8, less than 2^-16: the extent wins.
  EXPECT_EQ(offset_ray_origin({0.1f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, 1.0f).x, 0.1f + 0x1p-16f);
}

TEST(OffsetRayOrigin, ScalesWithTheScene) {
  // The same geometry a thousand times smaller moves a thousand times less (up to rounding).
  const glm::vec3 n = glm::vec3(0.0f, 0.6f, 0.8f);
  const glm::vec3 big = offset_ray_origin({0.0f, 0.5f, 0.25f}, n, 2.0f) - glm::vec3(0, 0.5f, 0.25f);
  const glm::vec3 small =
      offset_ray_origin({0.0f, 0.5e-3f, 0.25e-3f}, n, 2e-3f) - glm::vec3(0, 0.5e-3f, 0.25e-3f);
  EXPECT_NEAR(small.y / big.y, 1e-3, 1e-5);
  EXPECT_NEAR(small.z / big.z, 1e-3, 1e-5);
  EXPECT_EQ(kDefault.int_scale, 4.0f);
}

TEST(TriangleExtent, IsTheLargestEdgeComponent) {
  EXPECT_EQ(triangle_extent({1.0f, -3.0f, 0.5f}, {2.0f, 0.0f, -2.5f}), 3.0f);
}

// The SIMD offset (AVX2 builds) is the scalar reference bit for bit: points of every sign and
// magnitude (zeros of both signs, denormals, 1e-30 to 1e30), unit normals in every direction and
// along the axes, extents from 0 up.
TEST(OffsetRayOrigin, SimdEqualsTheScalarReferenceBitForBit) {
  Pcg32 rng(21, 22);
  auto coordinate = [&]() {
    switch (rng.next_u32() % 6) {
      case 0:
        return 0.0f;
      case 1:
        return -0.0f;
      case 2:
        return (rng.next_float() - 0.5f) * 0x1p-126f;  // denormals
      default: {
        const float magnitude =
            std::ldexp(1.0f + rng.next_float(), static_cast<int>(rng.next_u32() % 200) - 100);
        return rng.next_u32() % 2 ? magnitude : -magnitude;
      }
    }
  };
  for (int i = 0; i < 200000; ++i) {
    const glm::vec3 p(coordinate(), coordinate(), coordinate());
    glm::vec3 n(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f);
    if (i % 7 == 0) n = glm::vec3(0.0f);
    n[static_cast<int>(rng.next_u32() % 3)] += i % 5 == 0 ? 1.0f : 0.0f;
    const float len = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (len > 0.0f) n /= len;
    const float extent =
        i % 3 == 0 ? 0.0f
                   : std::ldexp(rng.next_float(), static_cast<int>(rng.next_u32() % 40) - 20);
    const glm::vec3 a = offset_ray_origin(p, n, extent);
    const glm::vec3 b = offset_ray_origin_scalar(p, n, extent);
    ASSERT_EQ(std::memcmp(&a, &b, sizeof a), 0) << i;
  }
}

}  // namespace
}  // namespace tritrace
