// The exact point/triangle distance: one hand-computed case in each of Ericson's seven Voronoi
// regions, triangles without area, and random cases checked against the variational inequality
// that characterises the closest point of a convex set.
#include "tritrace/geometry/point_triangle_distance.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>
#include <random>

namespace tritrace {
namespace {

const glm::dvec3 kA(0, 0, 0), kB(1, 0, 0), kC(0, 1, 0);

void expect_point(const TrianglePoint& got, const glm::dvec3& want, double distance2, double u,
                  double v) {
  EXPECT_NEAR(got.point.x, want.x, 1e-15);
  EXPECT_NEAR(got.point.y, want.y, 1e-15);
  EXPECT_NEAR(got.point.z, want.z, 1e-15);
  EXPECT_NEAR(got.distance2, distance2, 1e-14);
  EXPECT_NEAR(got.u, u, 1e-15);
  EXPECT_NEAR(got.v, v, 1e-15);
}

TEST(PointTriangleDistance, VertexRegions) {
  TrianglePoint r = closest_point_on_triangle(glm::dvec3(-1, -1, 2), kA, kB, kC);
  EXPECT_EQ(r.region, TriangleRegion::kVertexA);
  expect_point(r, kA, 6.0, 0.0, 0.0);
  r = closest_point_on_triangle(glm::dvec3(2, -1, 0), kA, kB, kC);
  EXPECT_EQ(r.region, TriangleRegion::kVertexB);
  expect_point(r, kB, 2.0, 1.0, 0.0);
  r = closest_point_on_triangle(glm::dvec3(-1, 3, 1), kA, kB, kC);
  EXPECT_EQ(r.region, TriangleRegion::kVertexC);
  expect_point(r, kC, 6.0, 0.0, 1.0);
}

TEST(PointTriangleDistance, EdgeRegions) {
  TrianglePoint r = closest_point_on_triangle(glm::dvec3(0.25, -2, 3), kA, kB, kC);
  EXPECT_EQ(r.region, TriangleRegion::kEdgeAB);
  expect_point(r, glm::dvec3(0.25, 0, 0), 13.0, 0.25, 0.0);
  r = closest_point_on_triangle(glm::dvec3(-2, 0.75, -1), kA, kB, kC);
  EXPECT_EQ(r.region, TriangleRegion::kEdgeAC);
  expect_point(r, glm::dvec3(0, 0.75, 0), 5.0, 0.0, 0.75);
  // (1, 1, 0.5) drops onto the hypotenuse x + y = 1 at (0.5, 0.5, 0).
  r = closest_point_on_triangle(glm::dvec3(1, 1, 0.5), kA, kB, kC);
  EXPECT_EQ(r.region, TriangleRegion::kEdgeBC);
  expect_point(r, glm::dvec3(0.5, 0.5, 0), 0.75, 0.5, 0.5);
}

TEST(PointTriangleDistance, FaceRegion) {
  const TrianglePoint r = closest_point_on_triangle(glm::dvec3(0.2, 0.3, -4), kA, kB, kC);
  EXPECT_EQ(r.region, TriangleRegion::kFace);
  expect_point(r, glm::dvec3(0.2, 0.3, 0), 16.0, 0.2, 0.3);
}

TEST(PointTriangleDistance, PointOnTheTriangleIsAtDistanceZero) {
  const TrianglePoint r = closest_point_on_triangle(glm::dvec3(0.25, 0.25, 0), kA, kB, kC);
  expect_point(r, glm::dvec3(0.25, 0.25, 0), 0.0, 0.25, 0.25);
}

TEST(PointTriangleDistance, CollinearCornersAreASegment) {
  // c beyond b: the triangle is the segment from a to c.
  const glm::dvec3 a(0, 0, 0), b(1, 0, 0), c(2, 0, 0);
  const TrianglePoint r = closest_point_on_triangle(glm::dvec3(1.5, 1, 0), a, b, c);
  EXPECT_EQ(r.region, TriangleRegion::kDegenerate);
  EXPECT_NEAR(r.distance2, 1.0, 1e-15);
  EXPECT_NEAR(r.point.x, 1.5, 1e-15);
  // The barycentrics give back the point.
  const glm::dvec3 back = (1 - r.u - r.v) * a + r.u * b + r.v * c;
  EXPECT_NEAR(glm::length(back - r.point), 0.0, 1e-15);
  // Beyond the far end: the end point.
  const TrianglePoint end = closest_point_on_triangle(glm::dvec3(3, 0, 2), a, b, c);
  EXPECT_NEAR(end.distance2, 5.0, 1e-14);
}

TEST(PointTriangleDistance, RepeatedCorners) {
  const glm::dvec3 p(1, 2, 3);
  const TrianglePoint one = closest_point_on_triangle(glm::dvec3(1, 2, 4), p, p, p);
  EXPECT_EQ(one.region, TriangleRegion::kDegenerate);
  EXPECT_EQ(one.distance2, 1.0);
  EXPECT_EQ(one.point, p);
  const glm::dvec3 o(0, 0, 0), c(0, 2, 0);
  const TrianglePoint two = closest_point_on_triangle(glm::dvec3(1, 1, 0), o, o, c);
  EXPECT_NEAR(two.distance2, 1.0, 1e-15);
  EXPECT_NEAR(two.point.y, 1.0, 1e-15);
}

TEST(PointTriangleDistance, SliverIsNearlyItsLongestEdge) {
  // Area 5e-10: the closest point to (1.5, 1, 0) is within 1e-9 of (1.5, 0, 0).
  const glm::dvec3 a(0, 0, 0), b(1, 0, 0), c(2, 1e-9, 0);
  const TrianglePoint r = closest_point_on_triangle(glm::dvec3(1.5, 1, 0), a, b, c);
  EXPECT_NEAR(std::sqrt(r.distance2), 1.0, 1e-9);
  EXPECT_NEAR(r.point.x, 1.5, 1e-9);
}

// q is the closest point of a convex set K to p exactly when (p - q) . (s - q) <= 0 for every s in
// K; for a triangle, checking its corners suffices (the expression is linear in s).
TEST(PointTriangleDistance, RandomCasesSatisfyTheOptimalityCondition) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(-2.0, 2.0);
  auto random_point = [&] { return glm::dvec3(x(rng), x(rng), x(rng)); };
  int regions[8] = {};
  for (int i = 0; i < 20000; ++i) {
    const glm::dvec3 a = random_point(), b = random_point(), c = random_point();
    const glm::dvec3 p = 2.0 * random_point();
    const TrianglePoint r = closest_point_on_triangle(p, a, b, c);
    ++regions[static_cast<int>(r.region)];
    ASSERT_GE(r.u, -1e-12);
    ASSERT_GE(r.v, -1e-12);
    ASSERT_LE(r.u + r.v, 1 + 1e-12);
    const glm::dvec3 back = (1 - r.u - r.v) * a + r.u * b + r.v * c;
    ASSERT_NEAR(glm::length(back - r.point), 0.0, 1e-12);
    const double scale = glm::length(p - r.point) * 8.0;
    for (const glm::dvec3& s : {a, b, c}) {
      ASSERT_LE(glm::dot(p - r.point, s - r.point), 1e-12 * scale) << i;
    }
    ASSERT_NEAR(r.distance2, glm::dot(p - r.point, p - r.point), 1e-12);
  }
  for (int region = 0; region < 7; ++region) EXPECT_GT(regions[region], 100) << region;
}

}  // namespace
}  // namespace tritrace
