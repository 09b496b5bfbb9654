// GeometrySet: geometry ids in the order added, every concatenated triangle located back to its
// geometry and index, bad input refused with the argument named, zero-area triangles kept but never
// hit, and first hits through the set's BVH equal to a double-precision brute force over the
// caller's own arrays.
#include "tritrace/accel/geometry_set.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "tritrace/error.h"

namespace tritrace {
namespace {

struct Geometry {
  std::vector<glm::vec3> vertices;
  std::vector<glm::uvec3> triangles;
};

// n random triangles in a cube of side 2 around `centre`, sharing vertices at random.
Geometry random_geometry(int n, glm::vec3 centre, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.0f, 1.0f);
  Geometry g;
  for (int i = 0; i < n + 2; ++i) {
    g.vertices.push_back(centre + glm::vec3(pos(rng), pos(rng), pos(rng)));
  }
  std::uniform_int_distribution<uint32_t> pick(0, static_cast<uint32_t>(g.vertices.size() - 1));
  for (int i = 0; i < n; ++i) g.triangles.emplace_back(pick(rng), pick(rng), pick(rng));
  return g;
}

// Möller–Trumbore in double on the caller's vertices: the oracle's t, or none. `near_edge` is set
// when the ray passes within 1e-5 (in barycentrics) of the triangle's border, where float
// rounding may decide either way.
std::optional<double> hit_in_double(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a,
                                    const glm::dvec3& b, const glm::dvec3& c, bool& near_edge) {
  const glm::dvec3 e1 = b - a, e2 = c - a;
  const glm::dvec3 p = glm::cross(d, e2);
  const double det = glm::dot(e1, p);
  if (det == 0.0) return std::nullopt;
  const glm::dvec3 s = o - a;
  const double u = glm::dot(s, p) / det;
  const glm::dvec3 q = glm::cross(s, e1);
  const double v = glm::dot(d, q) / det;
  const double t = glm::dot(e2, q) / det;
  const double margin = std::min({u, v, 1.0 - u - v});
  if (t > 0.0 && std::abs(margin) < 1e-5) near_edge = true;
  if (margin < 0.0 || t < 0.0) return std::nullopt;
  return t;
}

TEST(GeometrySetTest, IdsFollowTheOrderAddedAndLocateFindsEveryTriangle) {
  GeometrySet set;
  const Geometry a = random_geometry(5, glm::vec3(0.0f), 1);
  const Geometry b = random_geometry(0, glm::vec3(0.0f), 2);  // an empty geometry takes an id too
  const Geometry c = random_geometry(7, glm::vec3(3.0f), 3);
  EXPECT_EQ(set.add(a.vertices, a.triangles), 0u);
  EXPECT_EQ(set.add(b.vertices, b.triangles), 1u);
  EXPECT_EQ(set.add(c.vertices, c.triangles), 2u);
  EXPECT_EQ(set.geometry_count(), 3u);
  ASSERT_EQ(set.triangle_count(), 12u);
  const std::vector<const Geometry*> geometries = {&a, &b, &c};
  uint32_t prim = 0;
  for (uint32_t g = 0; g < 3; ++g) {
    EXPECT_EQ(set.first_prim(g), prim);
    for (uint32_t i = 0; i < geometries[g]->triangles.size(); ++i, ++prim) {
      const GeometrySet::Location at = set.locate(prim);
      EXPECT_EQ(at.geometry, g);
      EXPECT_EQ(at.prim, i);
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(set.mesh().vertex(prim, k),
                  geometries[g]->vertices[geometries[g]->triangles[i][k]]);
      }
    }
  }
}

TEST(GeometrySetTest, BadInputIsRefusedNamingTheArgumentAndLeavesTheSetUnchanged) {
  GeometrySet set;
  const std::vector<glm::vec3> vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<glm::uvec3> out_of_range = {{0, 1, 2}, {0, 1, 3}};
  try {
    set.add(vertices, out_of_range);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "triangles");
    EXPECT_EQ(e.reason(), "triangle 1 has vertex index 3, but there are 3 vertices");
  }
  std::vector<glm::vec3> not_finite = vertices;
  not_finite[2].y = std::numeric_limits<float>::quiet_NaN();
  try {
    set.add(not_finite, std::vector<glm::uvec3>{{0, 1, 2}});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), "vertices");
    EXPECT_EQ(e.reason(), "vertex 2 is not finite: (0, nan, 0)");
  }
  EXPECT_EQ(set.geometry_count(), 0u);
  EXPECT_EQ(set.triangle_count(), 0u);
}

TEST(GeometrySetTest, EmptySetBuildsAndEveryRayMisses) {
  GeometrySet set;
  set.build();
  Ray ray;
  EXPECT_FALSE(set.accel().intersect(ray).found());
}

TEST(GeometrySetTest, ZeroAreaTrianglesKeepTheirIndexButAreNeverHit) {
  // A segment, a point and a real triangle behind them, all in one geometry.
  const std::vector<glm::vec3> vertices = {{0, 0, 0},   {1, 1, 1},  {2, 2, 2},
                                           {-3, -3, 5}, {6, -3, 5}, {-3, 6, 5}};
  const std::vector<glm::uvec3> triangles = {{0, 1, 2}, {1, 1, 1}, {3, 4, 5}};
  GeometrySet set;
  set.add(vertices, triangles);
  set.build();
  ASSERT_EQ(set.triangle_count(), 3u);
  EXPECT_TRUE(set.degenerate(0));
  EXPECT_TRUE(set.degenerate(1));
  EXPECT_FALSE(set.degenerate(2));
  EXPECT_EQ(set.mesh().vertex(0, 2), vertices[2]);  // the mesh keeps the real corners
  // Rays from many directions through points of the segment (its corners and its middle) find
  // only the real triangle at z = 5 or nothing, never the segment or the point.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  for (int i = 0; i < 3000; ++i) {
    const glm::vec3 target = vertices[static_cast<size_t>(i % 3)] * (i % 2 ? 0.5f : 1.0f);
    Ray ray;
    ray.dir = glm::vec3(unit(rng), unit(rng), 0.2f + std::abs(unit(rng)));
    ray.origin = target - 3.0f * ray.dir;
    const Hit hit = set.accel().intersect(ray);
    if (hit.found()) {
      EXPECT_EQ(hit.prim, 2u) << i;
    }
  }
}

TEST(GeometrySetTest, AddingAfterBuildDropsTheTreeAndTheNextBuildSeesEverything) {
  GeometrySet set;
  const std::vector<glm::vec3> quad = {{-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1}};
  const std::vector<glm::uvec3> halves = {{0, 1, 2}, {0, 2, 3}};
  set.add(quad, halves);
  set.build();
  ASSERT_TRUE(set.built());
  Ray ray;  // from the origin along +z
  EXPECT_EQ(set.accel().intersect(ray).t, 1.0f);
  std::vector<glm::vec3> nearer = quad;
  for (glm::vec3& p : nearer) p.z = 0.5f;
  EXPECT_EQ(set.add(nearer, halves), 1u);
  EXPECT_FALSE(set.built());
  set.build();
  const Hit hit = set.accel().intersect(ray);
  ASSERT_TRUE(hit.found());
  EXPECT_EQ(hit.t, 0.5f);
  EXPECT_EQ(set.locate(hit.prim).geometry, 1u);
}

TEST(GeometrySetTest, FirstHitsMatchDoublePrecisionBruteForceOverTheCallersArrays) {
  std::vector<Geometry> geometries = {random_geometry(300, glm::vec3(0.0f), 11),
                                      random_geometry(200, glm::vec3(0.5f, 0.0f, 0.0f), 12),
                                      random_geometry(100, glm::vec3(0.0f, 0.5f, 0.0f), 13)};
  GeometrySet set;
  for (const Geometry& g : geometries) set.add(g.vertices, g.triangles);
  set.build();
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  int compared = 0, misses = 0;
  for (int i = 0; i < 2000; ++i) {
    Ray ray;
    ray.origin = 3.0f * glm::vec3(unit(rng), unit(rng), unit(rng));
    ray.dir = glm::vec3(unit(rng), unit(rng), unit(rng)) * 0.5f - ray.origin / 3.0f;
    // The oracle: the nearest and second nearest hit in double over every caller triangle.
    double best = std::numeric_limits<double>::infinity(), second = best;
    bool near_edge = false;
    uint32_t best_geometry = 0, best_prim = 0;
    for (uint32_t g = 0; g < geometries.size(); ++g) {
      const Geometry& geo = geometries[g];
      for (uint32_t k = 0; k < geo.triangles.size(); ++k) {
        const std::optional<double> t = hit_in_double(
            ray.origin, ray.dir, geo.vertices[geo.triangles[k][0]],
            geo.vertices[geo.triangles[k][1]], geo.vertices[geo.triangles[k][2]], near_edge);
        if (!t) continue;
        if (*t < best) {
          second = best;
          best = *t;
          best_geometry = g;
          best_prim = k;
        } else if (*t < second) {
          second = *t;
        }
      }
    }
    const Hit hit = set.accel().intersect(ray);
    if (std::isinf(best)) {
      if (!near_edge) {
        EXPECT_FALSE(hit.found()) << i;
      }
      ++misses;
      continue;
    }
    // Float's t is within a few float steps of the ray's reach (|o| / |d| plus t), so near an
    // edge or a near tie float may rightly answer differently from double.
    const double reach =
        best + static_cast<double>(glm::length(ray.origin) / glm::length(ray.dir)) + 1.0;
    if (near_edge || second - best < 1e-5 * reach) continue;
    ASSERT_TRUE(hit.found()) << i;
    const GeometrySet::Location at = set.locate(hit.prim);
    EXPECT_EQ(at.geometry, best_geometry) << i;
    EXPECT_EQ(at.prim, best_prim) << i;
    EXPECT_NEAR(hit.t, best, 1e-6 * reach) << i;
    ++compared;
  }
  EXPECT_GT(compared, 500);
  EXPECT_GT(misses, 100);
}

}  // namespace
}  // namespace tritrace
