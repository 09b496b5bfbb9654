#include "tritrace/accel/bvh/convex_groups.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numeric>
#include <tuple>

#include "tritrace/geometry/hit.h"

namespace tritrace::bvh {
namespace {

// Union-find over triangles with path halving.
struct Components {
  std::vector<uint32_t> parent;
  explicit Components(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  uint32_t find(uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void join(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

// A vertex position's bits, -0 as +0 (the same point).
std::array<uint32_t, 3> position_key(const glm::vec3& p) {
  return {std::bit_cast<uint32_t>(p.x + 0.0f), std::bit_cast<uint32_t>(p.y + 0.0f),
          std::bit_cast<uint32_t>(p.z + 0.0f)};
}

struct Vec3d {
  double x, y, z;
};
Vec3d to_double(const glm::vec3& p) {
  return {static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z)};
}

// Whether the component `tris` of `mesh` is convex as convex_groups.h says; its sign (+1: every
// vertex behind every normalize(cross(e2, e1)), -1: in front, 0: both, one plane) in *sign and each
// triangle's unit normal in `normals` (zero for a zero-area triangle).
bool convex_component(const TriangleMesh& mesh, std::span<const uint32_t> tris, int* sign,
                      std::vector<Vec3d>& normals) {
  // The component's distinct vertices.
  std::vector<std::array<uint32_t, 3>> keys;
  keys.reserve(3 * tris.size());
  for (uint32_t t : tris) {
    for (int c = 0; c < 3; ++c) keys.push_back(position_key(mesh.vertex(t, c)));
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  std::vector<Vec3d> vertices(keys.size());
  double largest = 0.0;
  for (size_t i = 0; i < keys.size(); ++i) {
    const glm::vec3 p(std::bit_cast<float>(keys[i][0]), std::bit_cast<float>(keys[i][1]),
                      std::bit_cast<float>(keys[i][2]));
    vertices[i] = to_double(p);
    largest = std::max(
        {largest, std::abs(vertices[i].x), std::abs(vertices[i].y), std::abs(vertices[i].z)});
  }
  // 8 ULPs of a float of the largest coordinate's size.
  const double tolerance = 8.0 * 0x1p-24 * largest;
  bool behind = true, in_front = true;  // every vertex behind / in front of every plane so far
  normals.resize(tris.size());
  for (size_t k = 0; k < tris.size(); ++k) {
    const Vec3d a = to_double(mesh.vertex(tris[k], 0)), b = to_double(mesh.vertex(tris[k], 1)),
                c = to_double(mesh.vertex(tris[k], 2));
    const Vec3d e1{b.x - a.x, b.y - a.y, b.z - a.z}, e2{c.x - a.x, c.y - a.y, c.z - a.z};
    // cross(e2, e1): the orientation of TriangleMesh's normal.
    Vec3d n{e2.y * e1.z - e2.z * e1.y, e2.z * e1.x - e2.x * e1.z, e2.x * e1.y - e2.y * e1.x};
    const double length = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (!(length > 0.0) || !std::isfinite(length)) {
      normals[k] = {0.0, 0.0, 0.0};
      continue;  // no plane: nothing to test, and rays leaving it skip nothing
    }
    n = {n.x / length, n.y / length, n.z / length};
    normals[k] = n;
    for (const Vec3d& v : vertices) {
      const double d = n.x * (v.x - a.x) + n.y * (v.y - a.y) + n.z * (v.z - a.z);
      if (d > tolerance) behind = false;
      if (d < -tolerance) in_front = false;
    }
    if (!behind && !in_front) return false;
  }
  *sign = behind && in_front ? 0 : behind ? 1 : -1;
  return true;
}

}  // namespace

ConvexGroups find_convex_groups(const TriangleMesh& mesh, size_t max_triangles) {
  const size_t n = mesh.size();
  ConvexGroups out;
  out.faces.assign(n, ConvexFace{});
  if (n == 0) return out;
  // Triangles sharing a vertex position: each corner's key sorted, equal keys joined.
  std::vector<std::tuple<std::array<uint32_t, 3>, uint32_t>> corners;
  corners.reserve(3 * n);
  for (uint32_t t = 0; t < n; ++t) {
    for (int c = 0; c < 3; ++c) corners.emplace_back(position_key(mesh.vertex(t, c)), t);
  }
  std::sort(corners.begin(), corners.end());
  Components components(n);
  for (size_t i = 1; i < corners.size(); ++i) {
    if (std::get<0>(corners[i]) == std::get<0>(corners[i - 1])) {
      components.join(std::get<1>(corners[i]), std::get<1>(corners[i - 1]));
    }
  }
  // The triangles of each component, in mesh order (roots are each component's least triangle).
  std::vector<uint32_t> root(n), first(n + 1, 0), members(n);
  for (uint32_t t = 0; t < n; ++t) ++first[(root[t] = components.find(t)) + 1];
  for (size_t i = 0; i < n; ++i) first[i + 1] += first[i];
  {
    std::vector<uint32_t> at(first.begin(), first.end() - 1);
    for (uint32_t t = 0; t < n; ++t) members[at[root[t]]++] = t;
  }
  std::vector<Vec3d> normals;
  for (uint32_t r = 0; r < n; ++r) {
    const std::span<const uint32_t> tris(members.data() + first[r], first[r + 1] - first[r]);
    if (tris.empty() || tris.size() > max_triangles) continue;
    int sign = 0;
    if (!convex_component(mesh, tris, &sign, normals)) continue;
    const uint32_t group = static_cast<uint32_t>(out.flat.size());
    out.flat.push_back(sign == 0 ? 1 : 0);
    const double s = sign < 0 ? -1.0 : 1.0;
    for (size_t k = 0; k < tris.size(); ++k) {
      ConvexFace& f = out.faces[tris[k]];
      f.n[0] = static_cast<float>(s * normals[k].x);
      f.n[1] = static_cast<float>(s * normals[k].y);
      f.n[2] = static_cast<float>(s * normals[k].z);
      f.group = group;
    }
  }
  return out;
}

namespace {

// The group of every triangle below `ref`, or kNoGroup; fills `out` for the nodes below.
uint32_t subtree_group(const WideBvh& tree, std::span<const ConvexFace> faces, uint32_t ref,
                       std::vector<ChildGroups>& out) {
  uint32_t group = kNoGroup;
  bool first = true;
  const auto take = [&](uint32_t g) {
    if (first) {
      group = g;
      first = false;
    } else if (g != group) {
      group = kNoGroup;
    }
  };
  if (ref & kLeafBit) {
    const TriangleBlock& b = tree.blocks[ref & ~kLeafBit];
    for (int l = 0; l < kWidth; ++l) {
      if (b.prim[l] == kNoHit) continue;
      take(b.prim[l] < faces.size() ? faces[b.prim[l]].group : kNoGroup);
    }
    return group;
  }
  const WideNode& node = tree.nodes[ref];
  for (int c = 0; c < kWidth; ++c) {
    const uint32_t child = node.child[c];
    const uint32_t g = child == kEmptyChild ? kNoGroup : subtree_group(tree, faces, child, out);
    out[ref].group[c] = g;
    if (child != kEmptyChild) take(g);
  }
  return group;
}

}  // namespace

std::vector<ChildGroups> child_groups(const WideBvh& tree, std::span<const ConvexFace> faces) {
  std::vector<ChildGroups> out(tree.nodes.size());
  for (ChildGroups& g : out) std::fill_n(g.group, kWidth, kNoGroup);
  if (!tree.nodes.empty()) subtree_group(tree, faces, 0, out);
  return out;
}

}  // namespace tritrace::bvh
