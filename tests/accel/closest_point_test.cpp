// Closest points through the BVH against brute force over every triangle (the same triangle away
// from ties, the same distance), and against analytic distances to a box, a plane and a sphere.
#include "tritrace/accel/bvh/closest_point.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <random>
#include <vector>

#include "query_meshes.h"
#include "test_rays.h"
#include "tritrace/accel/distance_queries.h"
#include "tritrace/geometry/point_triangle_distance.h"

namespace tritrace {
namespace {

using bvh::ClosestPoint;

std::vector<glm::vec3> random_points(int n, float extent, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> x(-extent, extent);
  std::vector<glm::vec3> p(n);
  for (auto& q : p) q = glm::vec3(x(rng), x(rng), x(rng));
  return p;
}

// The two least squared distances from q to the mesh's triangles, in double.
std::pair<double, double> two_nearest(const TriangleMesh& mesh, const glm::vec3& q) {
  double first = INFINITY, second = INFINITY;
  for (size_t t = 0; t < mesh.size(); ++t) {
    const double d =
        closest_point_on_triangle(q, mesh.v0()[t], mesh.v1()[t], mesh.v2()[t]).distance2;
    if (d < first) {
      second = first;
      first = d;
    } else if (d < second) {
      second = d;
    }
  }
  return {first, second};
}

void expect_matches_brute_force(const TriangleMesh& mesh, const std::vector<glm::vec3>& points,
                                const bvh::BuildConfig& config = {}) {
  const bvh::WideBvh tree = bvh::build_wide_bvh(mesh, config);
  std::vector<ClosestPoint> got(points.size());
  bvh::closest_points(tree, mesh, points, got);
  int compared = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const ClosestPoint want = bvh::closest_point_brute_force(mesh, points[i]);
    ASSERT_EQ(got[i].distance, want.distance) << i;
    const auto [first, second] = two_nearest(mesh, points[i]);
    ASSERT_EQ(static_cast<float>(std::sqrt(first)), want.distance);
    if (second > first * (1 + 1e-6)) {  // away from ties
      ASSERT_EQ(got[i].prim, want.prim) << i;
      ASSERT_EQ(got[i].point, want.point) << i;
      ASSERT_EQ(got[i].u, want.u);
      ASSERT_EQ(got[i].v, want.v);
      ++compared;
    }
  }
  EXPECT_GT(compared, static_cast<int>(points.size()) / 2);
}

TEST(ClosestPoint, MatchesBruteForceOnATriangleSoup) {
  const TriangleMesh soup = random_soup(3000, 11);
  expect_matches_brute_force(soup, random_points(3000, 1.5f, 12));
  // Points far away, where many subtrees lie at almost the same distance.
  expect_matches_brute_force(soup, random_points(300, 100.0f, 13));
}

TEST(ClosestPoint, MatchesBruteForceWithSmallLeavesAndMortonTrees) {
  const TriangleMesh soup = random_soup(2000, 21);
  bvh::BuildConfig fine;
  fine.block_size = 1;
  fine.max_leaf_size = 1;
  expect_matches_brute_force(soup, random_points(1000, 1.2f, 22), fine);
  bvh::BuildConfig morton;
  morton.method = bvh::BuildMethod::kMorton;
  expect_matches_brute_force(soup, random_points(1000, 1.2f, 23), morton);
}

TEST(ClosestPoint, MatchesBruteForceOnMixedMagnitudes) {
  const TriangleMesh soup = mixed_magnitude_soup(1000, 31);
  expect_matches_brute_force(soup, random_points(1000, 50.0f, 32));
}

// The distance to the surface of the box [-1, 1]^3, from outside and from inside.
double box_distance(const glm::dvec3& p) {
  const glm::dvec3 q = glm::abs(p) - 1.0;
  const double outside = glm::length(glm::max(q, 0.0));
  return outside > 0.0 ? outside : -std::max({q.x, q.y, q.z});
}

TEST(ClosestPoint, BoxDistancesAreAnalytic) {
  const TriangleMesh box = box_mesh(glm::dvec3(-1), glm::dvec3(1)).mesh();
  const bvh::WideBvh tree = bvh::build_wide_bvh(box);
  for (const glm::vec3& p : random_points(5000, 3.0f, 41)) {
    const ClosestPoint c = bvh::closest_point(tree, box, p);
    ASSERT_NEAR(c.distance, box_distance(p), 1e-6 * (1 + glm::length(p))) << p.x << p.y << p.z;
    // The point lies on the surface and at that distance.
    const glm::vec3 q = glm::abs(c.point);
    ASSERT_NEAR(std::max({q.x, q.y, q.z}), 1.0f, 1e-6f);
    ASSERT_NEAR(glm::length(glm::dvec3(c.point) - glm::dvec3(p)), c.distance, 1e-5);
  }
}

TEST(ClosestPoint, PlaneDistanceIsHeight) {
  // A 64 x 64 grid on z = 0.5 over [-4, 4]^2; points above its middle are |z - 0.5| away, with
  // their own x and y as the closest point.
  TriangleMesh grid;
  const int n = 64;
  auto at = [&](int i, int j) {
    return glm::vec3(-4.0f + 8.0f * i / n, -4.0f + 8.0f * j / n, 0.5f);
  };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      grid.add(at(i, j), at(i + 1, j), at(i + 1, j + 1), 0);
      grid.add(at(i, j), at(i + 1, j + 1), at(i, j + 1), 0);
    }
  }
  const bvh::WideBvh tree = bvh::build_wide_bvh(grid);
  std::mt19937 rng(51);
  std::uniform_real_distribution<float> xy(-3.9f, 3.9f), z(-10.0f, 10.0f);
  for (int i = 0; i < 3000; ++i) {
    const glm::vec3 p(xy(rng), xy(rng), z(rng));
    const ClosestPoint c = bvh::closest_point(tree, grid, p);
    ASSERT_NEAR(c.distance, std::abs(double(p.z) - 0.5), 1e-6);
    ASSERT_NEAR(c.point.x, p.x, 1e-6);
    ASSERT_NEAR(c.point.y, p.y, 1e-6);
  }
  // Beyond the edge the nearest point is on the boundary.
  EXPECT_NEAR(bvh::closest_point(tree, grid, glm::vec3(7, 0, 4.5f)).distance, 5.0f, 1e-6f);
}

TEST(ClosestPoint, SphereDistancesWithinTheTessellationBound) {
  const IndexedMesh sphere = icosphere(4, 2.0);
  const TriangleMesh mesh = sphere.mesh();
  const bvh::WideBvh tree = bvh::build_wide_bvh(mesh);
  // Every surface point lies between the inner radius and the sphere.
  const double inner = icosphere_inner_radius(sphere);
  ASSERT_GT(inner, 1.99);
  for (const glm::vec3& p : random_points(3000, 5.0f, 61)) {
    const double r = glm::length(glm::dvec3(p));
    const double d = bvh::closest_point(tree, mesh, p).distance;
    if (r >= 2.0) {
      ASSERT_GE(d, r - 2.0 - 1e-5);
      ASSERT_LE(d, r - inner + 1e-5);
    } else if (r <= inner) {
      ASSERT_GE(d, inner - r - 1e-5);
      ASSERT_LE(d, 2.0 - r + 1e-5);
    }
  }
}

TEST(ClosestPoint, EmptyMeshAndNonFiniteQueriesFindNothing) {
  const TriangleMesh empty;
  const bvh::WideBvh none = bvh::build_wide_bvh(empty);
  EXPECT_EQ(bvh::closest_point(none, empty, glm::vec3(0)).prim, kNoHit);
  const TriangleMesh box = box_mesh(glm::dvec3(-1), glm::dvec3(1)).mesh();
  const bvh::WideBvh tree = bvh::build_wide_bvh(box);
  const ClosestPoint c = bvh::closest_point(tree, box, glm::vec3(NAN, 0, 0));
  EXPECT_EQ(c.prim, kNoHit);
  EXPECT_TRUE(std::isinf(c.distance));
}

TEST(ClosestPoint, DegenerateTrianglesAreSegments) {
  TriangleMesh m;
  m.add(glm::vec3(0, 0, 0), glm::vec3(1, 0, 0), glm::vec3(2, 0, 0), 0);  // a segment
  m.add(glm::vec3(5, 5, 5), glm::vec3(5, 5, 5), glm::vec3(5, 5, 5), 0);  // a point
  const bvh::WideBvh tree = bvh::build_wide_bvh(m);
  ClosestPoint c = bvh::closest_point(tree, m, glm::vec3(1.5f, 3, 4));  // (5, 5, 5) is nearer
  EXPECT_EQ(c.prim, 1u);
  c = bvh::closest_point(tree, m, glm::vec3(1.5f, 0.6f, 0.8f));
  EXPECT_EQ(c.prim, 0u);
  EXPECT_FLOAT_EQ(c.distance, 1.0f);
  EXPECT_FLOAT_EQ(c.point.x, 1.5f);
  c = bvh::closest_point(tree, m, glm::vec3(5, 5, 7));
  EXPECT_EQ(c.prim, 1u);
  EXPECT_FLOAT_EQ(c.distance, 2.0f);
}

// GeometrySet collapses zero-area triangles onto their first corner in its tree so that rays miss
// them; closest points must still see the whole segment.
TEST(ClosestPoint, GeometrySetSeesZeroAreaTrianglesWhole) {
  GeometrySet set;
  const std::vector<glm::vec3> quad = {{10, 10, 0}, {11, 10, 0}, {11, 11, 0}};
  set.add(quad, std::vector<glm::uvec3>{{0, 1, 2}});
  const std::vector<glm::vec3> segment = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  set.add(segment, std::vector<glm::uvec3>{{0, 1, 2}});
  set.build();
  const std::vector<glm::vec3> points = {{1.5f, 0.6f, 0.8f}, {10.5f, 10.25f, -2}};
  std::vector<SurfacePoint> got(points.size());
  closest_points(set, points, got);
  EXPECT_EQ(got[0].geometry, 1u);
  EXPECT_EQ(got[0].prim, 0u);
  EXPECT_FLOAT_EQ(got[0].distance, 1.0f);
  EXPECT_FLOAT_EQ(got[0].point.x, 1.5f);
  EXPECT_EQ(got[0].normal, glm::vec3(0.0f));
  EXPECT_EQ(got[1].geometry, 0u);
  EXPECT_FLOAT_EQ(got[1].distance, 2.0f);
  // Counter-clockwise seen from +z: the caller's normal is +z.
  EXPECT_EQ(got[1].normal, glm::vec3(0, 0, 1));
  EXPECT_FLOAT_EQ(got[1].u, 0.25f);  // (10.5, 10.25) = 0.25 a + 0.5 b + 0.25 c
  EXPECT_FLOAT_EQ(got[1].v, 0.25f);
}

TEST(ClosestPoint, InsideTestCountsEdgesPerGeometryAndSignsDistances) {
  GeometrySet set;
  const IndexedMesh box = box_mesh(glm::dvec3(-1), glm::dvec3(1));
  std::vector<glm::vec3> v(box.vertices.begin(), box.vertices.end());
  std::vector<glm::uvec3> t;
  for (const auto& f : box.triangles) t.emplace_back(f[0], f[1], f[2]);
  set.add(v, t);
  t.pop_back();
  for (auto& p : v) p += glm::vec3(5, 0, 0);
  set.add(v, t);
  set.build();
  const InsideTest inside(set);
  ASSERT_EQ(inside.edges().size(), 2u);
  EXPECT_TRUE(inside.edges()[0].closed());
  EXPECT_EQ(inside.edges()[1].boundary, 3u);
  const std::vector<glm::vec3> points = {{0, 0, 0.5f}, {3, 0, 0}, {5, 0, 0}};
  std::vector<float> sdf(points.size());
  inside.signed_distance(set, points, sdf);
  EXPECT_FLOAT_EQ(sdf[0], -0.5f);
  EXPECT_FLOAT_EQ(sdf[1], 1.0f);
  EXPECT_FLOAT_EQ(sdf[2], -1.0f);  // 11 of 12 triangles: winding number 11/12
  EXPECT_NEAR(inside.winding_number(set, points[2]), 11.0 / 12.0, 1e-9);
}

}  // namespace
}  // namespace tritrace
