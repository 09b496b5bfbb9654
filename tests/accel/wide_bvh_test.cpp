// collapse_binary_bvh against an exhaustive search: on small binary trees, the wide nodes it makes
// have the least summed surface area of every valid collapse, found by listing them all.
#include "tritrace/accel/bvh/wide_bvh.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <map>
#include <vector>

#include "test_rays.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

using bvh::BinaryBvh;
using bvh::kWidth;

double area(const Bounds3& b) {
  const double x = double(b.hi.x) - b.lo.x, y = double(b.hi.y) - b.lo.y,
               z = double(b.hi.z) - b.lo.z;
  return 2.0 * (x * y + y * z + z * x);
}

// Every way to give binary node n's subtree at most `limit` slots of a wide node, as the list of
// binary nodes that take the slots: n itself, or a cover of its left child beside one of its
// right child.
std::vector<std::vector<uint32_t>> covers(const BinaryBvh& t, uint32_t n, size_t limit) {
  std::vector<std::vector<uint32_t>> out{{n}};
  const bvh::BinaryNode& node = t.nodes[n];
  if (node.is_leaf() || limit < 2) return out;
  for (const auto& a : covers(t, node.first, limit - 1)) {
    for (const auto& b : covers(t, node.right, limit - a.size())) {
      std::vector<uint32_t> both = a;
      both.insert(both.end(), b.begin(), b.end());
      out.push_back(both);
    }
  }
  return out;
}

// The least summed area of the wide nodes under and including inner node n made a wide node: its
// own area plus, over every cover of its two children in at most kWidth slots, the cheapest sum
// for the inner nodes among the slots.
double least_cost(const BinaryBvh& t, uint32_t n, std::map<uint32_t, double>& memo) {
  if (auto it = memo.find(n); it != memo.end()) return it->second;
  const bvh::BinaryNode& node = t.nodes[n];
  double best = std::numeric_limits<double>::infinity();
  for (const auto& a : covers(t, node.first, kWidth - 1)) {
    for (const auto& b : covers(t, node.right, kWidth - a.size())) {
      double c = 0.0;
      for (const auto* side : {&a, &b}) {
        for (uint32_t m : *side) {
          if (!t.nodes[m].is_leaf()) c += least_cost(t, m, memo);
        }
      }
      best = std::min(best, c);
    }
  }
  return memo[n] = area(node.bounds) + best;
}

// The summed area of the wide tree's nodes: the root's box, and every slot that holds a node.
double wide_cost(const bvh::WideBvh& w, const Bounds3& root_box) {
  double sum = area(root_box);
  for (const bvh::WideNode& n : w.nodes) {
    for (int i = 0; i < kWidth; ++i) {
      if (n.child[i] == bvh::kEmptyChild || (n.child[i] & bvh::kLeafBit)) continue;
      sum += area(Bounds3{{n.lo_x[i], n.lo_y[i], n.lo_z[i]}, {n.hi_x[i], n.hi_y[i], n.hi_z[i]}});
    }
  }
  return sum;
}

BinaryBvh small_leaves_tree(const TriangleMesh& mesh, uint32_t max_leaf) {
  std::vector<Bounds3> boxes(mesh.size());
  for (size_t i = 0; i < mesh.size(); ++i) boxes[i] = mesh.triangle_bounds(i);
  bvh::BuildConfig config;
  config.block_size = 1;
  config.max_leaf_size = max_leaf;
  return bvh::build_binned_sah(boxes, config);
}

void expect_least_area(const TriangleMesh& mesh, uint32_t max_leaf) {
  const BinaryBvh tree = small_leaves_tree(mesh, max_leaf);
  ASSERT_FALSE(tree.nodes[0].is_leaf());
  std::map<uint32_t, double> memo;
  const double least = least_cost(tree, 0, memo);
  const double got = wide_cost(bvh::collapse_binary_bvh(tree, mesh), tree.nodes[0].bounds);
  // The collapse sums areas relative to the root's in float: equal to a few float steps.
  EXPECT_NEAR(got, least, 1e-5 * least) << tree.nodes.size() << " binary nodes";
}

TEST(CollapseBinaryBvh, SummedNodeAreaIsTheLeastOfEveryCollapse) {
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(seed);
    expect_least_area(random_soup(40 + 7 * static_cast<int>(seed), seed), 1 + seed % 3);
  }
}

TEST(CollapseBinaryBvh, SummedNodeAreaIsTheLeastOnATerrain) {
  expect_least_area(make_terrain_scene(120).mesh, 2);
}

TEST(CollapseBinaryBvh, FillsNodesWhereTheGreedyCollapseLeftThemHalfEmpty) {
  // The earlier collapse (open the largest child until eight) left terrain:1m's nodes with 3.8
  // children on average; a least-area collapse packs small subtrees into their parents' slots.
  const TriangleMesh mesh = make_terrain_scene(100000).mesh;
  const bvh::WideBvh w = bvh::build_wide_bvh(mesh);
  size_t used = 0;
  for (const bvh::WideNode& n : w.nodes) {
    for (int i = 0; i < kWidth; ++i) used += n.child[i] != bvh::kEmptyChild ? 1 : 0;
  }
  EXPECT_GT(static_cast<double>(used) / static_cast<double>(w.nodes.size()), 5.0);
}

TEST(HugePageAllocator, BigArraysStartOnHugePageBoundaries) {
  // terrain(100000)'s blocks take about 4 MiB: on 2 MiB boundaries, so that transparent huge pages
  // can back them; the small node array keeps the ordinary aligned allocation.
  const bvh::WideBvh w = bvh::build_wide_bvh(make_terrain_scene(100000).mesh);
  ASSERT_GE(w.block_bytes(), kHugePageBytes);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(w.blocks.data()) % kHugePageBytes, 0u);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(w.nodes.data()) % alignof(bvh::WideNode), 0u);
  HugePageVector<bvh::WideNode> grown;
  for (int i = 0; i < 20000; ++i) grown.emplace_back();  // through sizes on both sides of 2 MiB
  EXPECT_EQ(reinterpret_cast<uintptr_t>(grown.data()) % kHugePageBytes, 0u);
}

}  // namespace
}  // namespace tritrace
