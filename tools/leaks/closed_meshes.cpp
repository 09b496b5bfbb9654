// The leak test's closed meshes. Positions are computed in double and rounded once, and every
// triangle refers to vertices by index, so neighbours share bit-identical vertices.
#include "leaks/closed_meshes.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "tritrace/scene/cornell_box.h"

namespace tritrace::leaks {
namespace {

struct D3 {
  double x, y, z;
};

glm::vec3 place(D3 p, glm::vec3 centre, double radius) {
  return {static_cast<float>(centre.x + radius * p.x), static_cast<float>(centre.y + radius * p.y),
          static_cast<float>(centre.z + radius * p.z)};
}

D3 normalised(D3 p) {
  const double len = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
  return {p.x / len, p.y / len, p.z / len};
}

// Joins a mesh's boundary edges (used by one triangle) into one loop and closes it with a fan. The
// lab's room and blocks each have one open quad.
void close_single_hole(IndexedMesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (const auto& t : mesh.triangles) {
    for (int i = 0; i < 3; ++i) directed[{t[i], t[(i + 1) % 3]}]++;
  }
  // A boundary edge a->b has no twin b->a; the hole's loop runs the other way round, b->a.
  std::map<uint32_t, uint32_t> next;
  for (const auto& [e, n] : directed) {
    if (!directed.contains({e.second, e.first})) next[e.second] = e.first;
  }
  if (next.empty()) return;
  std::vector<uint32_t> loop{next.begin()->first};
  while (true) {
    const uint32_t n = next.at(loop.back());
    if (n == loop.front()) break;
    loop.push_back(n);
    if (loop.size() > next.size()) throw std::logic_error(mesh.name + ": boundary is not one loop");
  }
  if (loop.size() != next.size()) throw std::logic_error(mesh.name + ": more than one hole");
  for (size_t i = 1; i + 1 < loop.size(); ++i) {
    mesh.triangles.push_back({loop[0], loop[i], loop[i + 1]});
  }
}

// Welds triangles [first, last) of a TriangleMesh by exact position equality.
IndexedMesh weld(const TriangleMesh& src, size_t first, size_t last, std::string name) {
  IndexedMesh mesh;
  mesh.name = std::move(name);
  auto index_of = [&](glm::vec3 p) {
    for (uint32_t i = 0; i < mesh.positions.size(); ++i) {
      if (mesh.positions[i] == p) return i;
    }
    mesh.positions.push_back(p);
    return static_cast<uint32_t>(mesh.positions.size() - 1);
  };
  for (size_t t = first; t < last; ++t) {
    mesh.triangles.push_back(
        {index_of(src.vertex(t, 0)), index_of(src.vertex(t, 1)), index_of(src.vertex(t, 2))});
  }
  return mesh;
}

}  // namespace

IndexedMesh make_uv_sphere(int rings, int segments, glm::vec3 centre, float radius) {
  IndexedMesh m;
  m.name = "uv-sphere " + std::to_string(rings) + "x" + std::to_string(segments);
  m.positions.push_back(place({0, 1, 0}, centre, radius));  // north pole
  for (int r = 1; r < rings; ++r) {
    const double theta = std::numbers::pi * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2.0 * std::numbers::pi * s / segments;
      m.positions.push_back(
          place({std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)},
                centre, radius));
    }
  }
  const auto south = static_cast<uint32_t>(m.positions.size());
  m.positions.push_back(place({0, -1, 0}, centre, radius));
  // Ring r (1-based) column s; the seam column `segments` is column 0 again.
  auto at = [&](int r, int s) {
    return static_cast<uint32_t>(1 + (r - 1) * segments + s % segments);
  };
  for (int s = 0; s < segments; ++s) {
    m.triangles.push_back({0, at(1, s + 1), at(1, s)});
    for (int r = 1; r + 1 < rings; ++r) {
      m.triangles.push_back({at(r, s), at(r, s + 1), at(r + 1, s + 1)});
      m.triangles.push_back({at(r, s), at(r + 1, s + 1), at(r + 1, s)});
    }
    m.triangles.push_back({south, at(rings - 1, s), at(rings - 1, s + 1)});
  }
  return m;
}

IndexedMesh make_icosphere(int levels, glm::vec3 centre, float radius) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<D3> p = {{-1, g, 0},  {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g},  {0, 1, g},
                       {0, -1, -g}, {0, 1, -g}, {g, 0, -1},  {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
  for (D3& q : p) q = normalised(q);
  std::vector<std::array<uint32_t, 3>> tris = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoint;
    auto mid = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      if (auto it = midpoint.find(key); it != midpoint.end()) return it->second;
      p.push_back(
          normalised({(p[a].x + p[b].x) / 2, (p[a].y + p[b].y) / 2, (p[a].z + p[b].z) / 2}));
      const auto i = static_cast<uint32_t>(p.size() - 1);
      midpoint[key] = i;
      return i;
    };
    std::vector<std::array<uint32_t, 3>> finer;
    for (const auto& [a, b, c] : tris) {
      const uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      finer.push_back({a, ab, ca});
      finer.push_back({b, bc, ab});
      finer.push_back({c, ca, bc});
      finer.push_back({ab, bc, ca});
    }
    tris = std::move(finer);
  }
  IndexedMesh m;
  m.name = "icosphere level " + std::to_string(levels);
  for (const D3& q : p) m.positions.push_back(place(q, centre, radius));
  m.triangles = std::move(tris);
  return m;
}

IndexedMesh make_cube(glm::vec3 centre, double yaw, double pitch) {
  IndexedMesh m;
  m.name = "cube";
  const double cy = std::cos(yaw), sy = std::sin(yaw), cp = std::cos(pitch), sp = std::sin(pitch);
  for (int i = 0; i < 8; ++i) {
    const D3 c{i & 1 ? 1.0 : -1.0, i & 2 ? 1.0 : -1.0, i & 4 ? 1.0 : -1.0};
    const D3 turned_x{c.x, cp * c.y - sp * c.z, sp * c.y + cp * c.z};  // pitch about x
    const D3 turned{cy * turned_x.x + sy * turned_x.z, turned_x.y,
                    -sy * turned_x.x + cy * turned_x.z};
    m.positions.push_back(place(turned, centre, 1.0));
  }
  // Corner i has bit 0 = +x, bit 1 = +y, bit 2 = +z; each face as a quad, split along a diagonal.
  const std::array<std::array<uint32_t, 4>, 6> faces = {
      {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}}};
  for (const auto& f : faces) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

std::vector<IndexedMesh> make_lab_boxes() {
  const Scene lab = make_cornell_box();
  std::vector<IndexedMesh> boxes = {weld(lab.mesh, 0, 10, "lab room + front wall"),
                                    weld(lab.mesh, 10, 20, "lab short block + bottom"),
                                    weld(lab.mesh, 20, 30, "lab tall block + bottom")};
  for (IndexedMesh& b : boxes) close_single_hole(b);
  return boxes;
}

std::vector<IndexedMesh> leak_test_meshes() {
  // Centres off the origin, so that vertex coordinates are not symmetric and rounding differs
  // between them.
  std::vector<IndexedMesh> meshes = {
      make_uv_sphere(24, 48, {0.3f, -0.2f, 0.7f}, 1.0f),
      make_icosphere(3, {-0.45f, 0.35f, 0.15f}, 1.3f),
      make_cube({0.1f, 0.2f, -0.3f}, 0.4, 0.7),
  };
  for (IndexedMesh& b : make_lab_boxes()) meshes.push_back(std::move(b));
  return meshes;
}

std::vector<EdgeUse> edge_uses(const IndexedMesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> count;
  for (const auto& t : mesh.triangles) {
    for (int i = 0; i < 3; ++i) count[std::minmax(t[i], t[(i + 1) % 3])]++;
  }
  std::vector<EdgeUse> edges;
  for (const auto& [e, n] : count) edges.push_back({e.first, e.second, n});
  return edges;
}

}  // namespace tritrace::leaks
