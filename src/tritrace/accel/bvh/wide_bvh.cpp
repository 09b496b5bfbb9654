// Collapsing the binary tree: each wide node takes a binary node's two children and keeps opening
// the child with the largest surface area until it has eight, so the boxes that most rays hit are
// split first.
#include "tritrace/accel/bvh/wide_bvh.h"

#include <tbb/blocked_range.h>

#include <algorithm>
#include <glm/common.hpp>

#include <cmath>
#include <limits>

#include "tritrace/geometry/hit.h"
#include "tritrace/parallel.h"

namespace tritrace::bvh {
namespace {

// Kernels round too: near an edge or vertex one may accept a ray that passes the exact triangle by
// about a float step times the ray's length. The boxes get that much room, scaled to the scene, so
// that the BVH finds every hit the brute-force loop finds with the same kernel (tested bit for
// bit).
constexpr float kBoxPadding = 0x1p-16f;

Bounds3 widened_triangle_bounds(const TriangleMesh& mesh, size_t tri, float pad) {
  Bounds3 b = mesh.triangle_bounds(tri);
  bool finite = true;
  for (int a = 0; a < 3; ++a) finite = finite && std::isfinite(b.lo[a]) && std::isfinite(b.hi[a]);
  if (!finite) {
    // A triangle with a non-finite vertex can never be hit (every kernel's test fails on NaN);
    // a point box keeps the build's arithmetic finite. Only the coordinates are checked: a finite
    // triangle whose box area overflows float is still a real triangle that brute force can hit.
    return Bounds3{glm::vec3(0.0f), glm::vec3(0.0f)};
  }
  constexpr float inf = std::numeric_limits<float>::infinity();
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = std::nextafter(b.lo[a] - pad, -inf);
    b.hi[a] = std::nextafter(b.hi[a] + pad, inf);
  }
  return b;
}

class Collapser {
 public:
  Collapser(const BinaryBvh& tree, const TriangleMesh& mesh, WideBvh& out)
      : tree_(tree), mesh_(mesh), out_(out) {}

  void run() {
    if (tree_.nodes.empty()) return;
    out_.nodes.emplace_back();
    if (tree_.nodes[0].is_leaf()) {
      // A root that is a leaf still gets a node, so traversal always starts at a node.
      init_node(0);
      set_child(0, 0, tree_.nodes[0]);
      return;
    }
    collapse(0, 0);
  }

 private:
  void init_node(uint32_t w) {
    WideNode& node = out_.nodes[w];
    constexpr float inf = std::numeric_limits<float>::infinity();
    for (int i = 0; i < kWidth; ++i) {
      node.lo_x[i] = node.lo_y[i] = node.lo_z[i] = inf;
      node.hi_x[i] = node.hi_y[i] = node.hi_z[i] = -inf;
      node.child[i] = kEmptyChild;
    }
  }

  uint32_t make_block(const BinaryNode& leaf) {
    const uint32_t index = static_cast<uint32_t>(out_.blocks.size());
    TriangleBlock& b = out_.blocks.emplace_back();
    constexpr float nan = std::numeric_limits<float>::quiet_NaN();
    for (int lane = 0; lane < kWidth; ++lane) {
      const bool used = lane < static_cast<int>(leaf.count);
      const uint32_t p = used ? tree_.prim_index[leaf.first + lane] : 0;
      for (int corner = 0; corner < 3; ++corner) {
        const glm::vec3 v = used ? mesh_.vertex(p, corner) : glm::vec3(nan);
        for (int axis = 0; axis < 3; ++axis) b.vertex[corner][axis][lane] = v[axis];
      }
      b.prim[lane] = used ? p : kNoHit;
    }
    return index;
  }

  void set_child(uint32_t w, int slot, const BinaryNode& child, uint32_t ref = 0) {
    WideNode& node = out_.nodes[w];
    node.lo_x[slot] = child.bounds.lo.x, node.hi_x[slot] = child.bounds.hi.x;
    node.lo_y[slot] = child.bounds.lo.y, node.hi_y[slot] = child.bounds.hi.y;
    node.lo_z[slot] = child.bounds.lo.z, node.hi_z[slot] = child.bounds.hi.z;
    node.child[slot] = child.is_leaf() ? (kLeafBit | make_block(child)) : ref;
  }

  // Fills wide node `w` from binary inner node `b`.
  void collapse(uint32_t w, uint32_t b) {
    init_node(w);
    uint32_t members[kWidth];
    int count = 0;
    members[count++] = tree_.nodes[b].first;
    members[count++] = tree_.nodes[b].right;
    while (count < kWidth) {
      int open = -1;
      float largest = -1.0f;
      for (int i = 0; i < count; ++i) {
        const BinaryNode& n = tree_.nodes[members[i]];
        if (!n.is_leaf() && n.bounds.area() > largest) {
          largest = n.bounds.area();
          open = i;
        }
      }
      if (open < 0) break;
      const BinaryNode& n = tree_.nodes[members[open]];
      members[open] = n.first;
      members[count++] = n.right;
    }
    for (int slot = 0; slot < count; ++slot) {
      const BinaryNode& child = tree_.nodes[members[slot]];
      if (child.is_leaf()) {
        set_child(w, slot, child);
      } else {
        const uint32_t cw = static_cast<uint32_t>(out_.nodes.size());
        out_.nodes.emplace_back();  // may reallocate: set the slot after, by index
        set_child(w, slot, child, cw);
        collapse(cw, members[slot]);
      }
    }
  }

  const BinaryBvh& tree_;
  const TriangleMesh& mesh_;
  WideBvh& out_;
};

}  // namespace

WideBvh build_wide_bvh(const TriangleMesh& mesh, const BuildConfig& config) {
  // The padding scales with the largest coordinate magnitude in the scene.
  const float magnitude = parallel::reduce(
      tbb::blocked_range<size_t>(0, mesh.size()), 0.0f,
      [&](const auto& r, float m) {
        for (size_t i = r.begin(); i != r.end(); ++i) {
          for (int c = 0; c < 3; ++c) {
            const glm::vec3 p = glm::abs(mesh.vertex(i, c));
            const float largest = std::max({p.x, p.y, p.z});
            if (std::isfinite(largest)) m = std::max(m, largest);
          }
        }
        return m;
      },
      [](float a, float b) { return std::max(a, b); });
  const float pad = magnitude * kBoxPadding;
  std::vector<Bounds3> bounds(mesh.size());
  parallel::for_range(tbb::blocked_range<size_t>(0, mesh.size()), [&](const auto& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) bounds[i] = widened_triangle_bounds(mesh, i, pad);
  });
  WideBvh out;
  out.triangles = mesh.size();
  {
    const BinaryBvh tree = build_binned_sah(bounds, config);
    std::vector<Bounds3>().swap(bounds);
    out.nodes.reserve(tree.nodes.size() / 4 + 1);
    out.blocks.reserve(tree.nodes.size() / 2 + 1);
    Collapser(tree, mesh, out).run();
  }
  out.nodes.shrink_to_fit();
  out.blocks.shrink_to_fit();
  return out;
}

}  // namespace tritrace::bvh
