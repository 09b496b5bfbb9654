// Hand-computed cases for every ray/triangle kernel: interior, edge and vertex hits, near misses,
// triangles behind the ray, parallel rays, degenerate triangles and the t interval.
#include "tritrace/geometry/intersect.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace tritrace {
namespace {

// The unit right triangle in the plane z = 0: v0 = (0,0,0), v1 = (1,0,0), v2 = (0,1,0), so a hit at
// (x, y, 0) has u = x and v = y.
const glm::vec3 kV0(0.0f), kE1(1.0f, 0.0f, 0.0f), kE2(0.0f, 1.0f, 0.0f);

Ray ray_down_z(float x, float y, float z = -1.0f) {
  Ray r;
  r.origin = {x, y, z};
  r.dir = {0.0f, 0.0f, 1.0f};
  return r;
}

class KernelTest : public ::testing::TestWithParam<Kernel> {
 protected:
  bool hit(const Ray& ray, TriangleHit& out, glm::vec3 v0 = kV0, glm::vec3 e1 = kE1,
           glm::vec3 e2 = kE2) const {
    out = {-7.0f, -7.0f, -7.0f};
    return intersect_triangle(GetParam(), ray, v0, e1, e2, out);
  }
};

TEST_P(KernelTest, InteriorHitGivesDistanceAndBarycentrics) {
  TriangleHit h;
  ASSERT_TRUE(hit(ray_down_z(0.25f, 0.25f), h));
  EXPECT_FLOAT_EQ(h.t, 1.0f);
  EXPECT_FLOAT_EQ(h.u, 0.25f);
  EXPECT_FLOAT_EQ(h.v, 0.25f);
}

TEST_P(KernelTest, ObliqueRayAgainstTiltedTriangle) {
  // Triangle v0 = (1,1,1), e1 = (2,0,0), e2 = (0,2,2). The point u = 0.25, v = 0.5 is
  // (1.5, 2, 2); the ray starts 3 units before it along the unit direction (0, 0.6, -0.8).
  const glm::vec3 v0(1.0f), e1(2.0f, 0.0f, 0.0f), e2(0.0f, 2.0f, 2.0f);
  Ray r;
  r.dir = {0.0f, 0.6f, -0.8f};
  r.origin = glm::vec3(1.5f, 2.0f, 2.0f) - 3.0f * r.dir;
  TriangleHit h;
  ASSERT_TRUE(hit(r, h, v0, e1, e2));
  EXPECT_NEAR(h.t, 3.0f, 1e-5f);
  EXPECT_NEAR(h.u, 0.25f, 1e-5f);
  EXPECT_NEAR(h.v, 0.5f, 1e-5f);
}

TEST_P(KernelTest, EdgeHitCountsAsHit) {
  TriangleHit h;
  ASSERT_TRUE(hit(ray_down_z(0.5f, 0.0f), h));  // edge v0-v1: v = 0
  EXPECT_FLOAT_EQ(h.u, 0.5f);
  EXPECT_EQ(h.v, 0.0f);
  ASSERT_TRUE(hit(ray_down_z(0.0f, 0.75f), h));  // edge v0-v2: u = 0
  EXPECT_EQ(h.u, 0.0f);
  ASSERT_TRUE(hit(ray_down_z(0.5f, 0.5f), h));  // edge v1-v2: u + v = 1
  EXPECT_FLOAT_EQ(h.u + h.v, 1.0f);
}

TEST_P(KernelTest, VertexHitCountsAsHit) {
  TriangleHit h;
  ASSERT_TRUE(hit(ray_down_z(0.0f, 0.0f), h));
  EXPECT_EQ(h.u, 0.0f);
  EXPECT_EQ(h.v, 0.0f);
  ASSERT_TRUE(hit(ray_down_z(1.0f, 0.0f), h));
  EXPECT_FLOAT_EQ(h.u, 1.0f);
  ASSERT_TRUE(hit(ray_down_z(0.0f, 1.0f), h));
  EXPECT_FLOAT_EQ(h.v, 1.0f);
}

TEST_P(KernelTest, JustOutsideEachEdgeMisses) {
  TriangleHit h;
  EXPECT_FALSE(hit(ray_down_z(0.5f, -1e-4f), h));
  EXPECT_FALSE(hit(ray_down_z(-1e-4f, 0.5f), h));
  EXPECT_FALSE(hit(ray_down_z(0.5f, 0.5001f), h));
  EXPECT_FALSE(hit(ray_down_z(1.0001f, 0.0f), h));
  EXPECT_FALSE(hit(ray_down_z(2.0f, 2.0f), h));
}

TEST_P(KernelTest, TriangleBehindTheOriginMisses) {
  TriangleHit h;
  EXPECT_FALSE(hit(ray_down_z(0.25f, 0.25f, 1.0f), h));  // would be t = -1
}

TEST_P(KernelTest, RayParallelToThePlaneMisses) {
  TriangleHit h;
  Ray above = ray_down_z(-1.0f, 0.25f, -1.0f);
  above.dir = {1.0f, 0.0f, 0.0f};
  EXPECT_FALSE(hit(above, h));
  Ray in_plane = ray_down_z(-1.0f, 0.25f, 0.0f);  // slides along the triangle's own plane
  in_plane.dir = {1.0f, 0.0f, 0.0f};
  EXPECT_FALSE(hit(in_plane, h));
}

TEST_P(KernelTest, DegenerateTriangleNeverHits) {
  TriangleHit h;
  const Ray r = ray_down_z(0.5f, 0.5f);
  EXPECT_FALSE(hit(r, h, kV0, glm::vec3(1.0f, 1.0f, 0.0f), glm::vec3(2.0f, 2.0f, 0.0f)));  // line
  EXPECT_FALSE(hit(r, h, glm::vec3(0.5f, 0.5f, 0.0f), glm::vec3(0.0f), glm::vec3(0.0f)));  // point
  EXPECT_FALSE(hit(ray_down_z(0.0f, 0.0f), h, kV0, glm::vec3(0.0f), glm::vec3(0.0f)));
}

TEST_P(KernelTest, DistanceLimitsAreInclusive) {
  Ray r = ray_down_z(0.25f, 0.25f);
  TriangleHit h;
  r.tmax = 1.0f;
  EXPECT_TRUE(hit(r, h));
  r.tmax = 0.999f;
  EXPECT_FALSE(hit(r, h));
  r.tmax = kRayTMax;
  r.tmin = 1.0f;
  EXPECT_TRUE(hit(r, h));
  r.tmin = 1.001f;
  EXPECT_FALSE(hit(r, h));
}

TEST_P(KernelTest, NonFiniteRaysMissWithoutProducingNaN) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  TriangleHit h;
  Ray r = ray_down_z(0.25f, 0.25f);
  r.dir = {nan, 0.0f, 1.0f};
  EXPECT_FALSE(hit(r, h));
  r.dir = {0.0f, 0.0f, inf};
  EXPECT_FALSE(hit(r, h));
  r = ray_down_z(nan, 0.25f);
  EXPECT_FALSE(hit(r, h));
  r = ray_down_z(0.25f, 0.25f);
  r.dir = {0.0f, 0.0f, 0.0f};  // zero direction: parallel to everything
  EXPECT_FALSE(hit(r, h));
}

TEST_P(KernelTest, TinyButValidTriangleIsHit) {
  // A triangle a millionth of a unit across: the determinant is about 1e-12, far from zero in
  // floating point, and the kernel must not treat it as degenerate.
  const glm::vec3 e1(1e-6f, 0.0f, 0.0f), e2(0.0f, 1e-6f, 0.0f);
  TriangleHit h;
  ASSERT_TRUE(hit(ray_down_z(0.25e-6f, 0.25e-6f), h, kV0, e1, e2));
  EXPECT_FLOAT_EQ(h.t, 1.0f);
  EXPECT_NEAR(h.u, 0.25f, 1e-4f);
}

TEST_P(KernelTest, MeshLoopEntryPointAgreesWithSingleTriangleEntryPoint) {
  // PreparedRay reads the mesh's arrays (the watertight kernel its exact vertices); on triangles
  // whose vertices are exact sums v0 + e1, v0 + e2 it must answer as the (v0, e1, e2) form does.
  const glm::vec3 v0s[2] = {kV0, glm::vec3(1.0f)};
  const glm::vec3 e1s[2] = {kE1, glm::vec3(2.0f, 0.0f, 0.0f)};
  const glm::vec3 e2s[2] = {kE2, glm::vec3(0.0f, 2.0f, 2.0f)};
  const glm::vec3 v1s[2] = {v0s[0] + e1s[0], v0s[1] + e1s[1]};
  const glm::vec3 v2s[2] = {v0s[0] + e2s[0], v0s[1] + e2s[1]};
  const TriangleArrays tris{v0s, v1s, v2s};
  for (float x : {-0.5f, 0.0f, 0.3f, 1.0f, 1.5f}) {
    for (float y : {-0.5f, 0.0f, 0.4f, 1.0f, 2.5f}) {
      Ray r = ray_down_z(x, y, -3.0f);
      r.dir = glm::normalize(glm::vec3(0.1f, 0.2f, 1.0f));
      for (size_t i = 0; i < 2; ++i) {
        TriangleHit single{}, looped{};
        const bool a = intersect_triangle(GetParam(), r, v0s[i], e1s[i], e2s[i], single);
        const bool b = with_kernel(
            GetParam(), [&]<Kernel K>() { return PreparedRay<K>(r).intersect(tris, i, looped); });
        ASSERT_EQ(a, b) << x << "," << y << " triangle " << i;
        if (a) {
          EXPECT_EQ(single.t, looped.t);
          EXPECT_EQ(single.u, looped.u);
          EXPECT_EQ(single.v, looped.v);
        }
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllKernels, KernelTest, ::testing::ValuesIn(kAllKernels),
                         [](const auto& info) {
                           std::string name(kernel_name(info.param));
                           std::erase(name, '-');
                           return name;
                         });

TEST(KernelNames, RoundTripAndRejectUnknown) {
  for (Kernel k : kAllKernels) EXPECT_EQ(parse_kernel(kernel_name(k)), k);
  EXPECT_EQ(parse_kernel("moller-trumbore"), Kernel::kMollerTrumbore);
  EXPECT_EQ(parse_kernel("watertight"), Kernel::kWatertight);
  EXPECT_FALSE(parse_kernel("Cramer").has_value());
  EXPECT_FALSE(parse_kernel("").has_value());
}

// prepare_watertight_axis<Kz> (the BVH's closest hit, which divides once for the box test and the
// kernel) against prepare_watertight, field for field and bit for bit.
WatertightRay prepared_with_axis(const Ray& ray) {
  const int kz = watertight_axis(ray.dir);
  const float sz = 1.0f / ray.dir[kz];
  if (kz == 0) return prepare_watertight_axis<0>(ray, sz);
  if (kz == 1) return prepare_watertight_axis<1>(ray, sz);
  return prepare_watertight_axis<2>(ray, sz);
}

void expect_same_bits(const WatertightRay& a, const WatertightRay& b) {
  EXPECT_EQ(a.kz, b.kz);
  const float fa[] = {a.ox, a.oy, a.oz, a.sx, a.sy, a.sz, a.tmin, a.tmax};
  const float fb[] = {b.ox, b.oy, b.oz, b.sx, b.sy, b.sz, b.tmin, b.tmax};
  for (int i = 0; i < 8; ++i) {
    EXPECT_EQ(std::bit_cast<uint32_t>(fa[i]), std::bit_cast<uint32_t>(fb[i])) << "field " << i;
  }
}

TEST(WatertightPrepare, FixedAxisVersionHandComputed) {
  Ray ray;
  ray.origin = {1.0f, 2.0f, 3.0f};
  ray.dir = {1.0f, -2.0f, 4.0f};
  const WatertightRay w = prepare_watertight_axis<2>(ray, 0.25f);
  EXPECT_EQ(w.kz, 2);
  EXPECT_EQ(w.ox, 1.0f);  // kx = 0, ky = 1
  EXPECT_EQ(w.oy, 2.0f);
  EXPECT_EQ(w.oz, 3.0f);
  EXPECT_EQ(w.sx, 0.25f);
  EXPECT_EQ(w.sy, -0.5f);
  EXPECT_EQ(w.sz, 0.25f);
  EXPECT_EQ(w.tmin, ray.tmin);
  EXPECT_EQ(w.tmax, ray.tmax);
}

TEST(WatertightPrepare, FixedAxisVersionGivesTheRunTimeAxisBits) {
  std::mt19937 rng(2711);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_int_distribution<int> exponent(-140, 30);
  std::vector<Ray> rays;
  for (int i = 0; i < 20000; ++i) {
    Ray r;
    for (int a = 0; a < 3; ++a) {
      r.origin[a] = std::ldexp(unit(rng), exponent(rng) / 4);
      r.dir[a] = std::ldexp(unit(rng), exponent(rng));  // magnitudes down to denormals
    }
    rays.push_back(r);
  }
  // Ties between axes, zero components of either sign, a zero direction, a denormal dominant
  // component (1 / dz overflows: the interval is emptied), non-finite origins and directions.
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float tiny = std::numeric_limits<float>::denorm_min();
  const glm::vec3 dirs[] = {{1, 1, 1},     {-1, 1, -1},  {0, 0, 0},     {-0.0f, 0, 0},
                            {0, -0.0f, 2}, {tiny, 0, 0}, {0, 0, -tiny}, {1, inf, 0},
                            {nan, 1, 0},   {3, -3, 0},   {0, 5, -5}};
  for (const glm::vec3& d : dirs) {
    Ray r;
    r.dir = d;
    rays.push_back(r);
    r.origin = {inf, 0, 0};
    rays.push_back(r);
    r.origin = {0, nan, 1};
    rays.push_back(r);
  }
  for (const Ray& r : rays) expect_same_bits(prepared_with_axis(r), prepare_watertight(r));
}

}  // namespace
}  // namespace tritrace
