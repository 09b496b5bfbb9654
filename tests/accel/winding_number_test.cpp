// The hierarchical winding number against analytic values (an octant's solid angle, a box with a
// face missing), analytic insides (box, sphere) and a point-in-polyhedron oracle: the parity of
// crossings along random rays, in double, on a bumpy closed mesh.
#include "tritrace/accel/bvh/winding_number.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <random>
#include <vector>

#include "query_meshes.h"

namespace tritrace {
namespace {

TEST(WindingNumber, OctantTriangleSubtendsAnEighth) {
  // The triangle through the three unit axis points covers one octant of the sphere of
  // directions seen from the origin: 4 pi / 8 steradians.
  const double w = bvh::triangle_winding(glm::dvec3(0), glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0),
                                         glm::dvec3(0, 0, 1));
  // Its normal cross(b - a, c - a) = (1, 1, 1) points away from the origin: positive, as inside a
  // mesh; the other orientation is negative.
  EXPECT_NEAR(w, 0.125, 1e-15);
  EXPECT_NEAR(bvh::triangle_winding(glm::dvec3(0), glm::dvec3(1, 0, 0), glm::dvec3(0, 0, 1),
                                    glm::dvec3(0, 1, 0)),
              -0.125, 1e-15);
}

TEST(WindingNumber, BoxIsOneInsideZeroOutsideMinusOneFlipped) {
  IndexedMesh m = box_mesh(glm::dvec3(-1), glm::dvec3(1));
  const TriangleMesh box = m.mesh();
  const bvh::WideBvh tree = bvh::build_wide_bvh(box);
  const bvh::WindingNumber wn(tree, box);
  EXPECT_NEAR(wn.at(tree, glm::vec3(0)), 1.0, 1e-12);
  EXPECT_NEAR(wn.at(tree, glm::vec3(0.9f, -0.99f, 0.5f)), 1.0, 1e-12);
  EXPECT_NEAR(wn.at(tree, glm::vec3(1.01f, 0, 0)), 0.0, 1e-12);
  EXPECT_NEAR(wn.at(tree, glm::vec3(100, 30, -70)), 0.0, 1e-3);
  for (auto& t : m.triangles) std::swap(t[1], t[2]);
  const TriangleMesh flipped = m.mesh();
  const bvh::WideBvh flipped_tree = bvh::build_wide_bvh(flipped);
  EXPECT_NEAR(bvh::WindingNumber(flipped_tree, flipped).at(flipped_tree, glm::vec3(0.3f)), -1.0,
              1e-12);
}

TEST(WindingNumber, BoxWithoutAFaceIsFiveSixthsAtItsCentre) {
  // Each face of a cube subtends a sixth of the sphere of directions from the centre.
  const TriangleMesh open = [] {
    const IndexedMesh m = box_mesh(glm::dvec3(-1), glm::dvec3(1));
    TriangleMesh out;
    for (size_t t = 2; t < m.triangles.size(); ++t) {
      const auto& f = m.triangles[t];
      out.add(glm::vec3(m.vertices[f[0]]), glm::vec3(m.vertices[f[1]]), glm::vec3(m.vertices[f[2]]),
              0);
    }
    return out;
  }();
  const bvh::WideBvh tree = bvh::build_wide_bvh(open);
  EXPECT_NEAR(bvh::WindingNumber(tree, open).at(tree, glm::vec3(0)), 5.0 / 6.0, 1e-12);
}

TEST(WindingNumber, SphereInsideIsAnalytic) {
  const IndexedMesh sphere = icosphere(4, 1.0);  // 5120 triangles: far subtrees are expanded
  const double inner = icosphere_inner_radius(sphere);
  const TriangleMesh mesh = sphere.mesh();
  const bvh::WideBvh tree = bvh::build_wide_bvh(mesh);
  const bvh::WindingNumber wn(tree, mesh);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> x(-3.0f, 3.0f);
  std::vector<glm::vec3> points;
  std::vector<uint8_t> want;
  while (points.size() < 4000) {
    const glm::vec3 p(x(rng), x(rng), x(rng));
    const double r = glm::length(glm::dvec3(p));
    if (r > inner && r < 1.0) continue;  // between the facets and the sphere
    points.push_back(p);
    want.push_back(r < 1.0 ? 1 : 0);
  }
  std::vector<uint8_t> got(points.size());
  wn.inside(tree, points, got);
  for (size_t i = 0; i < points.size(); ++i) ASSERT_EQ(got[i], want[i]) << i;
  // The values themselves, not only their side of 1/2: the far field's error is far below 1/2.
  for (size_t i = 0; i < 1000; ++i) ASSERT_NEAR(wn.at(tree, points[i]), want[i], 0.1) << i;
}

// Möller and Trumbore's ray/triangle test in double; -1 when the ray passes too near an edge or
// vertex to call (the oracle then tries another ray).
int crossing(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a, const glm::dvec3& b,
             const glm::dvec3& c) {
  const glm::dvec3 e1 = b - a, e2 = c - a, p = glm::cross(d, e2);
  const double det = glm::dot(e1, p);
  if (std::abs(det) < 1e-14) return 0;
  const glm::dvec3 s = o - a;
  const double u = glm::dot(s, p) / det;
  const glm::dvec3 q = glm::cross(s, e1);
  const double v = glm::dot(d, q) / det, t = glm::dot(e2, q) / det;
  constexpr double kMargin = 1e-9;
  if (u < -kMargin || v < -kMargin || u + v > 1 + kMargin || t < 0) return 0;
  if (u < kMargin || v < kMargin || u + v > 1 - kMargin || t < kMargin) return -1;
  return 1;
}

// Inside by the parity of crossings along the first ray that passes clear of every edge.
bool parity_inside(const IndexedMesh& m, const glm::dvec3& o, std::mt19937& rng) {
  std::normal_distribution<double> g;
  for (;;) {
    const glm::dvec3 d(g(rng), g(rng), g(rng));
    int count = 0;
    bool clear = true;
    for (const auto& t : m.triangles) {
      const int c = crossing(o, d, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]);
      if (c < 0) {
        clear = false;
        break;
      }
      count += c;
    }
    if (clear) return count % 2 == 1;
  }
}

TEST(WindingNumber, BumpyClosedMeshMatchesRayParity) {
  // An icosphere with each vertex pushed in or out at random: closed, not convex.
  IndexedMesh m = icosphere(3, 1.0);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> bump(0.6, 1.4);
  for (auto& v : m.vertices) v *= bump(rng);
  const TriangleMesh mesh = m.mesh();
  const bvh::WideBvh tree = bvh::build_wide_bvh(mesh);
  const bvh::WindingNumber wn(tree, mesh);
  std::uniform_real_distribution<float> x(-1.6f, 1.6f);
  int inside = 0;
  for (int i = 0; i < 1000; ++i) {
    const glm::vec3 p(x(rng), x(rng), x(rng));
    const bool want = parity_inside(m, glm::dvec3(p), rng);
    const double w = wn.at(tree, p);
    ASSERT_EQ(std::abs(w) > 0.5, want) << i << " w=" << w;
    ASSERT_NEAR(w, want ? 1.0 : 0.0, 0.1) << i;
    inside += want;
  }
  EXPECT_GT(inside, 100);
}

}  // namespace
}  // namespace tritrace
