// Collapsing the binary tree into eight-wide nodes: which binary nodes become wide nodes is chosen
// by dynamic programming so that their summed surface area (by the SAH, the expected number of
// wide-node visits per ray) is least, after Ylitie, Karras and Laine, "Efficient Incoherent Ray
// Traversal on GPUs Through Compressed Wide BVHs" (HPG 2017), sec. 3.1; the binary tree's leaves
// are kept as they are.
#include "tritrace/accel/bvh/wide_bvh.h"

#include <tbb/blocked_range.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <glm/common.hpp>

#include <cmath>
#include <limits>

#include "tritrace/accel/bvh/morton_builder.h"
#include "tritrace/geometry/hit.h"
#include "tritrace/math/next_float.h"
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
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = next_float_down(b.lo[a] - pad);
    b.hi[a] = next_float_up(b.hi[a] + pad);
  }
  return b;
}

// Surface area in double, where no box's area overflows; 0 for an empty box.
double area_in_double(const Bounds3& b) {
  if (b.is_empty()) return 0.0;
  const double x = double(b.hi.x) - b.lo.x, y = double(b.hi.y) - b.lo.y,
               z = double(b.hi.z) - b.lo.z;
  return 2.0 * (x * y + y * z + z * x);
}

// For every binary node n and slot count i (1 to kWidth): the least summed area of the wide nodes
// needed to hold n's subtree in at most i slots of a wide node (D(n, i) in the paper). A slot holds
// a leaf or a wide node; a binary leaf costs nothing, since the leaves are the same whatever the
// collapse. Areas are relative to the root's, so that float holds them; a root whose area is 0 or
// not finite counts each wide node as 1 instead (the fewest nodes).
class CollapsePlan {
 public:
  explicit CollapsePlan(const BinaryBvh& tree)
      : cost_(tree.nodes.size()), split_(tree.nodes.size()), wide_split_(tree.nodes.size()) {
    const double root_area = tree.nodes.empty() ? 0.0 : area_in_double(tree.nodes[0].bounds);
    const bool by_area = std::isfinite(root_area) && root_area > 0.0;
    // Children come after their parent in the builder's array, so a reverse sweep is bottom-up.
    for (size_t n = tree.nodes.size(); n-- > 0;) {
      const BinaryNode& node = tree.nodes[n];
      if (node.is_leaf()) {
        cost_[n].fill(0.0f);
        split_[n].fill(0);
        continue;
      }
      const auto& left = cost_[node.first];
      const auto& right = cost_[node.right];
      // n as a wide node: its own area, and its children sharing its kWidth slots.
      float best = std::numeric_limits<float>::infinity();
      uint8_t best_k = 1;
      for (int k = 1; k < kWidth; ++k) {
        const float c = left[k - 1] + right[kWidth - k - 1];
        if (c < best) best = c, best_k = static_cast<uint8_t>(k);
      }
      const float own =
          by_area ? static_cast<float>(area_in_double(node.bounds) / root_area) : 1.0f;
      const float wide = own + best;
      wide_split_[n] = best_k;
      cost_[n][0] = wide;
      split_[n][0] = 0;
      // In i >= 2 slots: n's children side by side, or n as one wide node, whichever is cheaper.
      for (int i = 2; i <= kWidth; ++i) {
        float c_best = wide;
        uint8_t s_best = 0;
        for (int k = 1; k < i; ++k) {
          const float c = left[k - 1] + right[i - k - 1];
          if (c < c_best) c_best = c, s_best = static_cast<uint8_t>(k);
        }
        cost_[n][i - 1] = c_best;
        split_[n][i - 1] = s_best;
      }
    }
  }

  // Slots for n's left child when n is a wide node (its right child gets the rest).
  int wide_split(uint32_t n) const { return wide_split_[n]; }
  // 0: n's subtree takes one slot (itself: a leaf, or a wide node); k > 0: its left child's
  // subtree gets k of the i slots and its right child's the rest.
  int split(uint32_t n, int slots) const { return split_[n][slots - 1]; }

 private:
  // Every entry is written by the sweep before it is read, so the arrays start uninitialised.
  HugePageVector<std::array<float, kWidth>> cost_;
  HugePageVector<std::array<uint8_t, kWidth>> split_;
  HugePageVector<uint8_t> wide_split_;
};

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
      set_child(0, 0, 0);
      fill_blocks();
      return;
    }
    {
      // The plan (41 bytes per binary node) is freed before the blocks are allocated: the build's
      // peak memory is at the end of fill_blocks, with the blocks, the binary tree and the mesh.
      const CollapsePlan plan(tree_);
      plan_ = &plan;
      // Both arrays at their final size from the start: no copy of a large array when one grows
      // or shrinks.
      size_t leaves = 0;
      for (const BinaryNode& n : tree_.nodes) leaves += n.is_leaf() ? 1 : 0;
      block_leaves_.reserve(leaves);
      out_.nodes.reserve(count_nodes(0));
      collapse(0, 0);
      plan_ = nullptr;
    }
    fill_blocks();
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

  // Numbers a block for binary leaf `leaf`; its triangles are copied in later, in parallel
  // (fill_blocks): gathering the vertices of ten million triangles is most of the collapse.
  uint32_t make_block(uint32_t leaf) {
    const uint32_t index = static_cast<uint32_t>(block_leaves_.size());
    block_leaves_.push_back(leaf);
    return index;
  }

  void fill_blocks() {
    out_.blocks.resize(block_leaves_.size());  // left uninitialised (HugePageAllocator::construct)
    parallel::for_range(tbb::blocked_range<size_t>(0, block_leaves_.size(), 1024),
                        [&](const auto& r) {
                          for (size_t i = r.begin(); i != r.end(); ++i) {
                            fill_block(out_.blocks[i], tree_.nodes[block_leaves_[i]]);
                          }
                        });
  }

  void fill_block(TriangleBlock& b, const BinaryNode& leaf) const {
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
  }

  // Slot `slot` of wide node w holds binary node b: a block for a leaf, else wide node `ref`.
  void set_child(uint32_t w, int slot, uint32_t b, uint32_t ref = 0) {
    const BinaryNode& child = tree_.nodes[b];
    WideNode& node = out_.nodes[w];
    node.lo_x[slot] = child.bounds.lo.x, node.hi_x[slot] = child.bounds.hi.x;
    node.lo_y[slot] = child.bounds.lo.y, node.hi_y[slot] = child.bounds.hi.y;
    node.lo_z[slot] = child.bounds.lo.z, node.hi_z[slot] = child.bounds.hi.z;
    node.child[slot] = child.is_leaf() ? (kLeafBit | make_block(b)) : ref;
  }

  // The subtrees that fill `slots` slots for binary node n, by the plan, appended to members.
  void gather(uint32_t n, int slots, uint32_t* members, int& count) const {
    const BinaryNode& node = tree_.nodes[n];
    const int k = node.is_leaf() ? 0 : plan_->split(n, slots);
    if (k == 0) {
      members[count++] = n;
      return;
    }
    gather(node.first, k, members, count);
    gather(node.right, slots - k, members, count);
  }

  // The wide nodes that collapse(., b) makes: b's and those under it.
  size_t count_nodes(uint32_t b) const {
    uint32_t members[kWidth];
    int count = 0;
    const int k = plan_->wide_split(b);
    gather(tree_.nodes[b].first, k, members, count);
    gather(tree_.nodes[b].right, kWidth - k, members, count);
    size_t nodes = 1;
    for (int slot = 0; slot < count; ++slot) {
      if (!tree_.nodes[members[slot]].is_leaf()) nodes += count_nodes(members[slot]);
    }
    return nodes;
  }

  // Fills wide node `w` from binary inner node `b`.
  void collapse(uint32_t w, uint32_t b) {
    init_node(w);
    uint32_t members[kWidth];
    int count = 0;
    const int k = plan_->wide_split(b);
    gather(tree_.nodes[b].first, k, members, count);
    gather(tree_.nodes[b].right, kWidth - k, members, count);
    for (int slot = 0; slot < count; ++slot) {
      const BinaryNode& child = tree_.nodes[members[slot]];
      if (child.is_leaf()) {
        set_child(w, slot, members[slot]);
      } else {
        const uint32_t cw = static_cast<uint32_t>(out_.nodes.size());
        out_.nodes.emplace_back();  // may reallocate: set the slot after, by index
        set_child(w, slot, members[slot], cw);
        collapse(cw, members[slot]);
      }
    }
  }

  const BinaryBvh& tree_;
  const TriangleMesh& mesh_;
  WideBvh& out_;
  const CollapsePlan* plan_ = nullptr;
  std::vector<uint32_t> block_leaves_;  // block i holds binary leaf block_leaves_[i]
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
  const BoxSource boxes = [&](size_t begin, size_t end, Bounds3* out) {
    for (size_t i = begin; i != end; ++i) out[i - begin] = widened_triangle_bounds(mesh, i, pad);
  };
  const BinaryBvh tree = config.method == BuildMethod::kMorton
                             ? build_morton(mesh.size(), boxes, config)
                             : build_binned_sah(mesh.size(), boxes, config);
  return collapse_binary_bvh(tree, mesh);
}

WideBvh collapse_binary_bvh(const BinaryBvh& tree, const TriangleMesh& mesh) {
  WideBvh out;
  out.triangles = mesh.size();
  Collapser(tree, mesh, out).run();
  return out;
}

}  // namespace tritrace::bvh
