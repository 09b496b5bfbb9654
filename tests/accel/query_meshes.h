// Closed test meshes with known insides for the closest-point and winding-number tests: an
// axis-aligned box and icospheres, triangles counter-clockwise seen from outside.
#pragma once

#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <map>
#include <utility>
#include <vector>

#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace {

struct IndexedMesh {
  std::vector<glm::dvec3> vertices;
  std::vector<std::array<int, 3>> triangles;

  TriangleMesh mesh() const {
    TriangleMesh m;
    for (const auto& t : triangles) {
      m.add(glm::vec3(vertices[t[0]]), glm::vec3(vertices[t[1]]), glm::vec3(vertices[t[2]]), 0);
    }
    return m;
  }
};

// The box [lo, hi], two triangles per face, normals cross(b - a, c - a) pointing out.
inline IndexedMesh box_mesh(const glm::dvec3& lo, const glm::dvec3& hi) {
  IndexedMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices.emplace_back(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
  }
  // Each face's corners in counter-clockwise order seen from outside.
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

// The icosahedron subdivided `levels` times, vertices on the sphere of `radius` about the origin.
inline IndexedMesh icosphere(int levels, double radius) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<glm::dvec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                               {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                               {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : v) p = glm::normalize(p);
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      v.push_back(glm::normalize(v[a] + v[b]));
      return midpoint[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> next;
    for (const auto& tri : f) {
      const int ab = mid(tri[0], tri[1]), bc = mid(tri[1], tri[2]), ca = mid(tri[2], tri[0]);
      next.push_back({tri[0], ab, ca});
      next.push_back({tri[1], bc, ab});
      next.push_back({tri[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    f = std::move(next);
  }
  IndexedMesh m;
  for (const auto& p : v) m.vertices.push_back(radius * p);
  m.triangles = std::move(f);
  return m;
}

// A lower bound on the distance from the origin to the icosphere's surface: the least distance to
// any triangle's plane. Points nearer the origin are surely inside.
inline double icosphere_inner_radius(const IndexedMesh& m) {
  double r = 1e300;
  for (const auto& t : m.triangles) {
    const glm::dvec3 a = m.vertices[t[0]], b = m.vertices[t[1]], c = m.vertices[t[2]];
    const glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
    r = std::min(r, std::abs(glm::dot(n, a)));
  }
  return r;
}

}  // namespace tritrace
