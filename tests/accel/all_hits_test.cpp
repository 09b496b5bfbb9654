// Every crossing along a ray (accel/bvh/all_hits.h): the BVH's lists equal a brute-force loop over
// every triangle with the same tie-broken rule bit for bit (awkward rays aimed at edges and
// vertices included), and equal a double-precision Möller–Trumbore oracle on random rays away from
// edges. On closed meshes (a cube, an icosphere, a box tessellated as a grid) rays aimed exactly
// through shared edges and vertices (dyadic directions from grid points, so the kernel's shear is
// exact and the ray really meets the edge) count each crossing once: 1 from inside a convex mesh,
// 2 along a line through its interior, an even number along any line, as the analytic box says.
#include "tritrace/accel/bvh/all_hits.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <map>
#include <random>
#include <vector>

#include "test_rays.h"
#include "tritrace/accel/geometry_set.h"
#include "tritrace/geometry/crossing.h"

namespace tritrace {
namespace {

using bvh::Intersections;

struct IndexedMesh {
  std::vector<glm::vec3> vertices;
  std::vector<glm::uvec3> triangles;
};

GeometrySet set_of(const IndexedMesh& m) {
  GeometrySet set;
  set.add(m.vertices, m.triangles);
  set.build();
  return set;
}

GeometrySet set_of(const TriangleMesh& mesh) {
  IndexedMesh m;
  for (size_t t = 0; t < mesh.size(); ++t) {
    for (int c = 0; c < 3; ++c) m.vertices.push_back(mesh.vertex(t, c));
    const auto i = static_cast<uint32_t>(3 * t);
    m.triangles.emplace_back(i, i + 1, i + 2);
  }
  return set_of(m);
}

// The box [0, n]^3 with each face an n x n grid of squares, each split into two triangles along
// alternating diagonals (so that vertices have fans of 4, 6 or 8 triangles). Integer coordinates:
// shared vertices are bit-identical.
IndexedMesh grid_box(int n) {
  IndexedMesh m;
  std::map<std::array<int, 3>, uint32_t> index;
  auto vertex = [&](std::array<int, 3> p) {
    auto [it, added] = index.emplace(p, static_cast<uint32_t>(m.vertices.size()));
    if (added) m.vertices.emplace_back(p[0], p[1], p[2]);
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis) {
    for (int side : {0, n}) {
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          auto at = [&](int di, int dj) {
            std::array<int, 3> p{};
            p[axis] = side;
            p[(axis + 1) % 3] = i + di;
            p[(axis + 2) % 3] = j + dj;
            return vertex(p);
          };
          const uint32_t a = at(0, 0), b = at(1, 0), c = at(1, 1), d = at(0, 1);
          if ((i + j) % 2 == 0) {
            m.triangles.emplace_back(a, b, c);
            m.triangles.emplace_back(a, c, d);
          } else {
            m.triangles.emplace_back(a, b, d);
            m.triangles.emplace_back(b, c, d);
          }
        }
      }
    }
  }
  return m;
}

// An icosahedron subdivided `levels` times, vertices on the unit sphere, each shared vertex stored
// once.
IndexedMesh icosphere(int levels) {
  IndexedMesh m;
  const float g = (1.0f + std::sqrt(5.0f)) / 2.0f;
  for (const glm::vec3& p :
       {glm::vec3(-1, g, 0), glm::vec3(1, g, 0), glm::vec3(-1, -g, 0), glm::vec3(1, -g, 0),
        glm::vec3(0, -1, g), glm::vec3(0, 1, g), glm::vec3(0, -1, -g), glm::vec3(0, 1, -g),
        glm::vec3(g, 0, -1), glm::vec3(g, 0, 1), glm::vec3(-g, 0, -1), glm::vec3(-g, 0, 1)}) {
    m.vertices.push_back(glm::normalize(p));
  }
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> middle;
    auto mid = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      auto [it, added] = middle.emplace(key, static_cast<uint32_t>(m.vertices.size()));
      if (added) m.vertices.push_back(glm::normalize(m.vertices[a] + m.vertices[b]));
      return it->second;
    };
    std::vector<glm::uvec3> finer;
    for (const glm::uvec3& t : m.triangles) {
      const uint32_t ab = mid(t[0], t[1]), bc = mid(t[1], t[2]), ca = mid(t[2], t[0]);
      finer.insert(finer.end(), {{t[0], ab, ca}, {t[1], bc, ab}, {t[2], ca, bc}, {ab, bc, ca}});
    }
    m.triangles = std::move(finer);
  }
  return m;
}

// Brute force with the same rule: every triangle of the mesh, sorted as the BVH sorts.
std::vector<Hit> brute_force_crossings(const TriangleMesh& mesh, const GeometrySet& set,
                                       const Ray& ray) {
  std::vector<Hit> hits;
  bool finite = true;
  for (int a = 0; a < 3; ++a) finite = finite && std::isfinite(ray.origin[a]);
  if (!finite || !(ray.tmin <= ray.tmax)) return hits;
  const WatertightRay w = prepare_watertight(ray);
  for (uint32_t i = 0; i < mesh.size(); ++i) {
    if (set.degenerate(i)) continue;
    TriangleHit h;
    if (cross_watertight(w, mesh.v0()[i], mesh.v1()[i], mesh.v2()[i], h)) {
      hits.push_back(Hit{h.t, h.u, h.v, i});
    }
  }
  std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) {
    return a.t < b.t || (a.t == b.t && a.prim < b.prim);
  });
  return hits;
}

void expect_same_hits(const std::vector<Hit>& want, const Hit* got, size_t n, size_t ray) {
  ASSERT_EQ(n, want.size()) << "ray " << ray;
  for (size_t k = 0; k < n; ++k) {
    EXPECT_EQ(got[k].prim, want[k].prim) << "ray " << ray;
    EXPECT_EQ(got[k].t, want[k].t) << "ray " << ray;
    EXPECT_EQ(got[k].u, want[k].u) << "ray " << ray;
    EXPECT_EQ(got[k].v, want[k].v) << "ray " << ray;
  }
}

TEST(AllHitsTest, BvhListsEqualBruteForceWithTheSameRuleBitForBit) {
  for (uint32_t seed : {1u, 2u}) {
    const TriangleMesh soup = seed == 1 ? random_soup(3000, seed) : mixed_magnitude_soup(500, seed);
    const GeometrySet set = set_of(soup);
    const std::vector<Ray> rays = awkward_rays(set.mesh(), 1500, seed + 10);
    Intersections list;
    bvh::list_intersections(set.tree(), rays, list);
    std::vector<uint32_t> counts(rays.size());
    bvh::count_intersections(set.tree(), rays, counts);
    ASSERT_EQ(list.ray_splits.size(), rays.size() + 1);
    for (size_t i = 0; i < rays.size(); ++i) {
      const std::vector<Hit> want = brute_force_crossings(set.mesh(), set, rays[i]);
      const size_t n = list.ray_splits[i + 1] - list.ray_splits[i];
      expect_same_hits(want, list.hits.data() + list.ray_splits[i], n, i);
      EXPECT_EQ(counts[i], n) << i;
    }
  }
}

// Möller–Trumbore in double: the ray's t on the triangle, or -1; near_edge when the ray passes
// within 1e-5 (barycentric) of its border, where float may rightly decide otherwise.
double double_crossing(const Ray& ray, const glm::dvec3& a, const glm::dvec3& b,
                       const glm::dvec3& c, bool& near_edge) {
  const glm::dvec3 o(ray.origin), d(ray.dir);
  const glm::dvec3 e1 = b - a, e2 = c - a;
  const glm::dvec3 p = glm::cross(d, e2);
  const double det = glm::dot(e1, p);
  if (det == 0.0) return -1.0;
  const glm::dvec3 s = o - a;
  const double u = glm::dot(s, p) / det;
  const glm::dvec3 q = glm::cross(s, e1);
  const double v = glm::dot(d, q) / det;
  const double t = glm::dot(e2, q) / det;
  const double margin = std::min({u, v, 1.0 - u - v});
  if (std::abs(margin) < 1e-5 && t >= ray.tmin && t <= ray.tmax) near_edge = true;
  if (margin < 0.0 || t < ray.tmin || t > ray.tmax) return -1.0;
  return t;
}

TEST(AllHitsTest, ListsMatchADoublePrecisionOracleAwayFromEdges) {
  const TriangleMesh soup = random_soup(2000, 7);
  const GeometrySet set = set_of(soup);
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::vector<Ray> rays(2000);
  for (size_t i = 0; i < rays.size(); ++i) {
    rays[i].origin = 2.0f * glm::vec3(unit(rng), unit(rng), unit(rng));
    rays[i].dir = glm::vec3(unit(rng), unit(rng), unit(rng));
    if (i % 3 == 0) rays[i].tmax = 1.0f + unit(rng);
  }
  Intersections list;
  bvh::list_intersections(set.tree(), rays, list);
  size_t compared = 0, crossings = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    bool near_edge = false;
    std::vector<std::pair<double, uint32_t>> want;
    for (uint32_t k = 0; k < soup.size(); ++k) {
      const double t =
          double_crossing(rays[i], soup.v0()[k], soup.v1()[k], soup.v2()[k], near_edge);
      if (t >= 0.0) want.emplace_back(t, k);
    }
    if (near_edge) continue;
    std::sort(want.begin(), want.end());
    const size_t n = list.ray_splits[i + 1] - list.ray_splits[i];
    ASSERT_EQ(n, want.size()) << i;
    const Hit* got = list.hits.data() + list.ray_splits[i];
    for (size_t k = 0; k < n; ++k) {
      // Crossings closer than float can order may come in either order.
      const bool tie = (k > 0 && want[k].first - want[k - 1].first < 1e-5) ||
                       (k + 1 < n && want[k + 1].first - want[k].first < 1e-5);
      if (!tie) {
        EXPECT_EQ(got[k].prim, want[k].second) << i;
      }
      EXPECT_NEAR(got[k].t, want[k].first, 1e-5 * (1.0 + want[k].first)) << i;
    }
    ++compared;
    crossings += n;
  }
  EXPECT_GT(compared, 1900u);
  EXPECT_GT(crossings, 500u);
}

// The directions whose shear is exact from grid points: components in {0, +-1, +-2}, with the
// dominant one's ratio to the others a power of two.
std::vector<glm::vec3> dyadic_directions() {
  std::vector<glm::vec3> out;
  for (int x = -2; x <= 2; ++x) {
    for (int y = -2; y <= 2; ++y) {
      for (int z = -2; z <= 2; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        const int m = std::max({std::abs(x), std::abs(y), std::abs(z)});
        if (m == 2 && std::abs(x) % 2 + std::abs(y) % 2 + std::abs(z) % 2 == 0) continue;
        out.emplace_back(x, y, z);
      }
    }
  }
  return out;
}

// The line o + t d (all t) and the box [0, n]^3: 2 when it passes through the open interior, 0
// when it misses the closed box, -1 when it only touches the boundary (any even count is right).
int analytic_box_crossings(const glm::vec3& o, const glm::vec3& d, int n) {
  double lo = -1e30, hi = 1e30;
  bool interior = true;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0f) {
      if (o[a] < 0.0f || o[a] > static_cast<float>(n)) return 0;
      if (o[a] == 0.0f || o[a] == static_cast<float>(n)) interior = false;
      continue;
    }
    double t0 = (0.0 - o[a]) / d[a], t1 = (n - static_cast<double>(o[a])) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    lo = std::max(lo, t0);
    hi = std::min(hi, t1);
  }
  if (lo > hi) return 0;
  return interior && lo < hi ? 2 : -1;
}

TEST(AllHitsTest, GridBoxCountsEachCrossingOnceThroughEdgesAndVertices) {
  constexpr int kN = 4;
  const GeometrySet set = set_of(grid_box(kN));
  ASSERT_EQ(set.triangle_count(), 6u * 2 * kN * kN);
  const std::vector<glm::vec3> directions = dyadic_directions();
  std::vector<Ray> inside, lines;
  for (const glm::vec3& d : directions) {
    // From every interior grid point: rays through grid vertices and edges of the faces.
    for (int x = 1; x < kN; ++x) {
      for (int y = 1; y < kN; ++y) {
        for (int z = 1; z < kN; ++z) {
          inside.push_back(Ray{glm::vec3(x, y, z), d});
        }
      }
    }
    // Whole lines: from grid points and half-grid points around the box, back along -d so that
    // the ray starts outside, including lines along faces and edges of the box.
    for (int x = -1; x <= 2 * kN + 1; x += 3) {
      for (int y = -1; y <= 2 * kN + 1; ++y) {
        for (int z = -1; z <= 2 * kN + 1; z += 2) {
          const glm::vec3 p = 0.5f * glm::vec3(x, y, z);
          lines.push_back(Ray{p - 16.0f * d, d});
          // From a million units back: the BVH's boxes must still be padded enough for the
          // kernel's rounding at a far origin (the shear stays exact for these values).
          if ((x + y + z) % 5 == 0) lines.push_back(Ray{p - 1048576.0f * d, d});
        }
      }
    }
  }
  // The rays really meet edges and vertices: for many of them the plain watertight kernel, whose
  // edges are inclusive, hits several triangles.
  size_t on_edges = 0;
  for (const Ray& ray : inside) {
    const WatertightRay w = prepare_watertight(ray);
    int hits = 0;
    TriangleHit h;
    for (size_t t = 0; t < set.triangle_count(); ++t) {
      hits +=
          intersect_watertight(w, set.mesh().v0()[t], set.mesh().v1()[t], set.mesh().v2()[t], h);
    }
    on_edges += hits > 1;
  }
  EXPECT_GT(on_edges, inside.size() / 4);
  std::vector<uint32_t> counts(inside.size());
  bvh::count_intersections(set.tree(), inside, counts);
  for (size_t i = 0; i < inside.size(); ++i) {
    ASSERT_EQ(counts[i], 1u) << "from (" << inside[i].origin.x << ", " << inside[i].origin.y << ", "
                             << inside[i].origin.z << ") along (" << inside[i].dir.x << ", "
                             << inside[i].dir.y << ", " << inside[i].dir.z << ")";
  }
  counts.resize(lines.size());
  bvh::count_intersections(set.tree(), lines, counts);
  size_t through = 0, touching = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    const int want = analytic_box_crossings(lines[i].origin, lines[i].dir, kN);
    const auto& r = lines[i];
    if (want >= 0) {
      ASSERT_EQ(counts[i], static_cast<uint32_t>(want))
          << "from (" << r.origin.x << ", " << r.origin.y << ", " << r.origin.z << ") along ("
          << r.dir.x << ", " << r.dir.y << ", " << r.dir.z << ")";
      through += want == 2;
    } else {
      ASSERT_EQ(counts[i] % 2, 0u) << i;
      ASSERT_LE(counts[i], 2u) << i;
      ++touching;
    }
  }
  EXPECT_GT(through, 1000u);
  EXPECT_GT(touching, 100u);
}

// A closed, non-convex solid made of unit voxels: a 3 x 3 x 2 block with a pit in the middle of
// its top and a notch at one top corner. Its surface is every voxel face with an empty neighbour,
// each square split along alternating diagonals; integer coordinates.
bool filled(int x, int y, int z) {
  if (x < 0 || y < 0 || z < 0 || x > 2 || y > 2 || z > 1) return false;
  return !(z == 1 && ((x == 1 && y == 1) || (x == 0 && y == 0)));
}

IndexedMesh notched_block() {
  IndexedMesh m;
  std::map<std::array<int, 3>, uint32_t> index;
  auto vertex = [&](std::array<int, 3> p) {
    auto [it, added] = index.emplace(p, static_cast<uint32_t>(m.vertices.size()));
    if (added) m.vertices.emplace_back(p[0], p[1], p[2]);
    return it->second;
  };
  for (int x = -1; x <= 3; ++x) {
    for (int y = -1; y <= 3; ++y) {
      for (int z = -1; z <= 2; ++z) {
        for (int axis = 0; axis < 3; ++axis) {
          std::array<int, 3> next{x, y, z};
          ++next[axis];
          if (filled(x, y, z) == filled(next[0], next[1], next[2])) continue;
          auto at = [&](int di, int dj) {
            std::array<int, 3> p = next;  // the face between the two voxels lies at next[axis]
            p[(axis + 1) % 3] += di;
            p[(axis + 2) % 3] += dj;
            return vertex(p);
          };
          const uint32_t a = at(0, 0), b = at(1, 0), c = at(1, 1), d = at(0, 1);
          if ((x + y + z) % 2 == 0) {
            m.triangles.emplace_back(a, b, c);
            m.triangles.emplace_back(a, c, d);
          } else {
            m.triangles.emplace_back(a, b, d);
            m.triangles.emplace_back(b, c, d);
          }
        }
      }
    }
  }
  return m;
}

TEST(AllHitsTest, ParityFromVoxelCentresSaysInsideANonConvexSolid) {
  const GeometrySet set = set_of(notched_block());
  // The full block shows 9 + 9 + 4 * 6 = 42 squares; the pit takes one top square and shows its
  // floor and four walls (+4), the corner notch trades its three squares for three (0): 46.
  ASSERT_EQ(set.triangle_count(), 2u * 46);
  std::vector<Ray> rays;
  std::vector<bool> inside;
  for (const glm::vec3& d : dyadic_directions()) {
    for (int x = -1; x <= 3; ++x) {
      for (int y = -1; y <= 3; ++y) {
        for (int z = -1; z <= 2; ++z) {
          rays.push_back(Ray{glm::vec3(x, y, z) + 0.5f, d});
          inside.push_back(filled(x, y, z));
        }
      }
    }
  }
  std::vector<uint32_t> counts(rays.size());
  bvh::count_intersections(set.tree(), rays, counts);
  size_t through_edges = 0;  // rays on which the plain kernel hits more triangles than it crosses
  for (size_t i = 0; i < rays.size(); ++i) {
    const WatertightRay w = prepare_watertight(rays[i]);
    uint32_t hits = 0;
    TriangleHit h;
    for (size_t t = 0; t < set.triangle_count(); ++t) {
      hits +=
          intersect_watertight(w, set.mesh().v0()[t], set.mesh().v1()[t], set.mesh().v2()[t], h);
    }
    through_edges += hits > counts[i];
  }
  EXPECT_GT(through_edges, rays.size() / 4);
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(counts[i] % 2, inside[i] ? 1u : 0u)
        << "from (" << rays[i].origin.x << ", " << rays[i].origin.y << ", " << rays[i].origin.z
        << ") along (" << rays[i].dir.x << ", " << rays[i].dir.y << ", " << rays[i].dir.z << ")";
  }
}

TEST(AllHitsTest, CubeCountsOnceThroughItsDiagonalsEdgesAndCorners) {
  const GeometrySet set = set_of(grid_box(1));
  ASSERT_EQ(set.triangle_count(), 12u);
  // From the centre through each corner, edge midpoint and face diagonal midpoint: one crossing.
  std::vector<Ray> rays;
  for (int x = -2; x <= 2; ++x) {
    for (int y = -2; y <= 2; ++y) {
      for (int z = -2; z <= 2; ++z) {
        if (x || y || z) rays.push_back(Ray{glm::vec3(0.5f), glm::vec3(x, y, z)});
      }
    }
  }
  std::vector<uint32_t> counts(rays.size());
  bvh::count_intersections(set.tree(), rays, counts);
  for (size_t i = 0; i < rays.size(); ++i) EXPECT_EQ(counts[i], 1u) << i;
  // The space diagonal as a whole line, through two opposite corners: two crossings, listed in
  // order at the corners (t = 1 and 2 from (-1, -1, -1)).
  Intersections list;
  const std::vector<Ray> diagonal = {Ray{glm::vec3(-1.0f), glm::vec3(1.0f)}};
  bvh::list_intersections(set.tree(), diagonal, list);
  ASSERT_EQ(list.hits.size(), 2u);
  EXPECT_EQ(list.hits[0].t, 1.0f);
  EXPECT_EQ(list.hits[1].t, 2.0f);
}

TEST(AllHitsTest, IcosphereCountsOnceThroughEveryVertexAndEdge) {
  const IndexedMesh sphere = icosphere(2);
  const GeometrySet set = set_of(sphere);
  std::vector<Ray> from_centre, lines;
  std::vector<glm::vec3> targets = sphere.vertices;
  for (const glm::uvec3& t : sphere.triangles) {
    for (int c = 0; c < 3; ++c) {
      targets.push_back(0.5f * (sphere.vertices[t[c]] + sphere.vertices[t[(c + 1) % 3]]));
    }
  }
  for (const glm::vec3& p : targets) {
    from_centre.push_back(Ray{glm::vec3(0.0f), p});
    lines.push_back(Ray{-3.0f * p, p});  // through the centre: in and out
  }
  std::vector<uint32_t> counts(from_centre.size());
  bvh::count_intersections(set.tree(), from_centre, counts);
  for (size_t i = 0; i < counts.size(); ++i) EXPECT_EQ(counts[i], 1u) << i;
  bvh::count_intersections(set.tree(), lines, counts);
  for (size_t i = 0; i < counts.size(); ++i) EXPECT_EQ(counts[i], 2u) << i;
}

TEST(AllHitsTest, TwoTrianglesSharingAnEdgeOrAFanSharingAVertexCountOnce) {
  // A square split along its diagonal; rays straight down through the diagonal and its ends.
  IndexedMesh quad;
  quad.vertices = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  quad.triangles = {{0, 1, 2}, {0, 2, 3}};
  const GeometrySet square = set_of(quad);
  std::vector<Ray> rays;
  for (float s : {0.25f, 0.5f, 0.75f}) rays.push_back(Ray{glm::vec3(s, s, 0), glm::vec3(0, 0, 1)});
  std::vector<uint32_t> counts(rays.size());
  bvh::count_intersections(square.tree(), rays, counts);
  for (uint32_t c : counts) EXPECT_EQ(c, 1u);
  // Six triangles around (0, 0, 1), and an oblique ray through that centre.
  IndexedMesh fan;
  fan.vertices.emplace_back(0, 0, 1);
  for (int k = 0; k < 6; ++k) {
    const float angle = static_cast<float>(k) * 1.0471976f;
    fan.vertices.emplace_back(std::cos(angle), std::sin(angle), 1.0f);
    fan.triangles.emplace_back(0, 1 + k, 1 + (k + 1) % 6);
  }
  const GeometrySet hexagon = set_of(fan);
  rays = {Ray{glm::vec3(0, 0, 0), glm::vec3(0, 0, 1)},
          Ray{glm::vec3(-1, -2, -1), glm::vec3(1, 2, 2)},
          Ray{glm::vec3(0, 0, 2), glm::vec3(0, 0, -1)}};
  bvh::count_intersections(hexagon.tree(), rays, counts);
  for (uint32_t c : counts) EXPECT_EQ(c, 1u);
  // Grazing: in the plane of the fan, nothing.
  EXPECT_EQ(bvh::count_crossings(hexagon.tree(), Ray{glm::vec3(-2, 0, 1), glm::vec3(1, 0, 0)}), 0u);
}

TEST(AllHitsTest, IntervalLimitsTheCrossingsAndBadRaysCrossNothing) {
  const GeometrySet set = set_of(grid_box(1));
  Ray ray{glm::vec3(0.5f, 0.5f, -1.0f), glm::vec3(0, 0, 1)};
  EXPECT_EQ(bvh::count_crossings(set.tree(), ray), 2u);
  ray.tmax = 1.0f;  // the near face at t = 1 exactly is inside the interval
  EXPECT_EQ(bvh::count_crossings(set.tree(), ray), 1u);
  ray.tmin = 1.5f;
  ray.tmax = 3.0f;
  EXPECT_EQ(bvh::count_crossings(set.tree(), ray), 1u);
  ray.tmin = 4.0f;  // tmin > tmax
  EXPECT_EQ(bvh::count_crossings(set.tree(), ray), 0u);
  ray = Ray{glm::vec3(0.5f, 0.5f, -1.0f), glm::vec3(0.0f)};
  EXPECT_EQ(bvh::count_crossings(set.tree(), ray), 0u);
  ray.dir = glm::vec3(0, 0, std::nanf(""));
  EXPECT_EQ(bvh::count_crossings(set.tree(), ray), 0u);
}

TEST(AllHitsTest, ZeroAreaTrianglesAreNeverCrossed) {
  IndexedMesh m = grid_box(1);
  // A segment and a point on the box's surface, listed last.
  m.triangles.emplace_back(0, 1, 1);
  m.triangles.emplace_back(2, 2, 2);
  const GeometrySet set = set_of(m);
  std::vector<Ray> rays;
  for (const glm::vec3& p : m.vertices) rays.push_back(Ray{glm::vec3(0.5f), p - glm::vec3(0.5f)});
  std::vector<uint32_t> counts(rays.size());
  bvh::count_intersections(set.tree(), rays, counts);
  for (uint32_t c : counts) EXPECT_EQ(c, 1u);
}

}  // namespace
}  // namespace tritrace
