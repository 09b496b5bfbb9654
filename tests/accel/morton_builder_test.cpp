// The Morton-code builder against a plain restatement of its order (codes made bit by bit here, the
// primitives sorted by std::sort) and the structure every binary tree must have: each primitive in
// one leaf, leaves full runs of the curve, every box exactly the union of what lies under it,
// children after their parents, the same tree with one thread as with several.
#include "tritrace/accel/bvh/morton_builder.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "test_rays.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

using bvh::BinaryBvh;

std::vector<Bounds3> boxes_of(const TriangleMesh& mesh) {
  std::vector<Bounds3> boxes(mesh.size());
  for (size_t i = 0; i < mesh.size(); ++i) boxes[i] = mesh.triangle_bounds(i);
  return boxes;
}

BinaryBvh build(const std::vector<Bounds3>& boxes, uint32_t max_leaf = bvh::kMaxLeafSize) {
  return bvh::build_morton(boxes.size(),
                           [&](size_t begin, size_t end, Bounds3* out) {
                             std::copy(boxes.begin() + static_cast<std::ptrdiff_t>(begin),
                                       boxes.begin() + static_cast<std::ptrdiff_t>(end), out);
                           },
                           {.max_leaf_size = max_leaf});
}

// The order the builder must produce, restated: each box's centre (0.5 lo + 0.5 hi in float)
// quantised to 1024 cells per axis over the centres' bounds (x = (c - lo) * s in float with
// s = 1024 / extent rounded to float, the cell trunc(x) clamped to [0, 1023]), the cells' bits
// interleaved one at a time with x highest, then the primitives sorted by (code, index).
std::vector<uint32_t> morton_order(const std::vector<Bounds3>& boxes) {
  std::vector<glm::vec3> centres(boxes.size());
  glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-lo);
  for (size_t i = 0; i < boxes.size(); ++i) {
    centres[i] = 0.5f * boxes[i].lo + 0.5f * boxes[i].hi;
    lo = glm::min(lo, centres[i]);
    hi = glm::max(hi, centres[i]);
  }
  std::vector<std::pair<uint32_t, uint32_t>> keyed(boxes.size());
  for (size_t i = 0; i < boxes.size(); ++i) {
    uint32_t cell[3];
    for (int a = 0; a < 3; ++a) {
      const double extent = double{hi[a]} - double{lo[a]};
      const float scale = extent > 0.0 ? static_cast<float>(1024.0 / extent) : 0.0f;
      const float x = (centres[i][a] - lo[a]) * scale;
      cell[a] = x > 0.0f ? static_cast<uint32_t>(std::min(x, 1023.0f)) : 0u;
    }
    uint32_t code = 0;
    for (int bit = 9; bit >= 0; --bit) {
      for (int a = 0; a < 3; ++a) code = code << 1 | ((cell[a] >> bit) & 1u);
    }
    keyed[i] = {code, static_cast<uint32_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<uint32_t> order(boxes.size());
  for (size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
  return order;
}

// The union of the boxes of the primitives under node i, computed from the leaves up here.
Bounds3 union_under(const BinaryBvh& tree, const std::vector<Bounds3>& boxes, uint32_t i) {
  const bvh::BinaryNode& n = tree.nodes[i];
  Bounds3 b = Bounds3::empty();
  if (n.is_leaf()) {
    for (uint32_t k = n.first; k < n.first + n.count; ++k) b.extend(boxes[tree.prim_index[k]]);
    return b;
  }
  b.extend(union_under(tree, boxes, n.first));
  b.extend(union_under(tree, boxes, n.right));
  return b;
}

void check_tree(const BinaryBvh& tree, const std::vector<Bounds3>& boxes, uint32_t max_leaf) {
  ASSERT_EQ(tree.prim_index.size(), boxes.size());
  if (boxes.empty()) {
    EXPECT_TRUE(tree.nodes.empty());
    return;
  }
  std::vector<int> seen(boxes.size(), 0);
  std::vector<uint32_t> todo{0};
  size_t visited = 0, short_leaves = 0;
  while (!todo.empty()) {
    const uint32_t i = todo.back();
    todo.pop_back();
    ASSERT_LT(i, tree.nodes.size());
    ++visited;
    const bvh::BinaryNode& n = tree.nodes[i];
    const Bounds3 want = union_under(tree, boxes, i);
    EXPECT_TRUE(n.bounds.lo == want.lo && n.bounds.hi == want.hi) << "node " << i;
    if (n.is_leaf()) {
      EXPECT_LE(n.count, max_leaf);
      EXPECT_EQ(n.first % max_leaf, 0u) << "leaves start at multiples of the leaf size";
      short_leaves += n.count < max_leaf ? 1 : 0;
      for (uint32_t k = n.first; k < n.first + n.count; ++k) ++seen[tree.prim_index[k]];
      continue;
    }
    EXPECT_EQ(n.first, i + 1) << "depth first: the left child follows its parent";
    EXPECT_GT(n.right, n.first);
    for (uint32_t c : {n.first, n.right}) todo.push_back(c);
  }
  EXPECT_EQ(visited, tree.nodes.size()) << "unreachable nodes";
  EXPECT_LE(short_leaves, 1u) << "only the last run of the curve may be short";
  for (size_t p = 0; p < boxes.size(); ++p) EXPECT_EQ(seen[p], 1) << "primitive " << p;
}

TEST(MortonBuilder, LeavesFollowTheCurveInFullRuns) {
  for (const auto& [mesh, leaf] :
       {std::tuple{make_terrain_scene(30000).mesh, 8u}, std::tuple{random_soup(5001, 3), 8u},
        std::tuple{random_soup(1003, 4), 3u}, std::tuple{random_soup(200, 5), 1u}}) {
    const std::vector<Bounds3> boxes = boxes_of(mesh);
    const BinaryBvh tree = build(boxes, leaf);
    check_tree(tree, boxes, leaf);
    const std::vector<uint32_t> want = morton_order(boxes);
    EXPECT_TRUE(
        std::equal(tree.prim_index.begin(), tree.prim_index.end(), want.begin(), want.end()))
        << mesh.size() << " primitives";
  }
}

TEST(MortonBuilder, SmallAndDegenerateInputs) {
  for (int n : {0, 1, 7, 8, 9, 17}) {
    const std::vector<Bounds3> boxes = boxes_of(random_soup(n, 11));
    check_tree(build(boxes), boxes, bvh::kMaxLeafSize);
  }
  // Every centre in one cell: the ranges are halved, in index order.
  const std::vector<Bounds3> same(1000, Bounds3{glm::vec3(1.0f), glm::vec3(2.0f)});
  const BinaryBvh tree = build(same);
  check_tree(tree, same, bvh::kMaxLeafSize);
  for (uint32_t i = 0; i < same.size(); ++i) EXPECT_EQ(tree.prim_index[i], i);
  // Centres at the extremes of float: the grid's scale is 0 there, not inf or NaN.
  std::vector<Bounds3> far = boxes_of(random_soup(100, 12));
  far.push_back({glm::vec3(-3e38f), glm::vec3(-3e38f)});
  far.push_back({glm::vec3(3e38f), glm::vec3(3e38f)});
  check_tree(build(far), far, bvh::kMaxLeafSize);
}

// Subtrees are built in tasks from 16384 primitives up; with one thread they run in order.
TEST(MortonBuilder, ParallelBuildMakesTheSerialTree) {
  const std::vector<Bounds3> boxes = boxes_of(make_terrain_scene(100000).mesh);
  BinaryBvh serial;
  tbb::task_arena(1).execute([&] { serial = build(boxes); });
  const BinaryBvh parallel = build(boxes);
  check_tree(parallel, boxes, bvh::kMaxLeafSize);
  EXPECT_TRUE(parallel.prim_index == serial.prim_index);
  // Numbered depth first, so the arrays themselves are the same.
  ASSERT_EQ(parallel.nodes.size(), serial.nodes.size());
  int differences = 0;
  for (size_t i = 0; i < serial.nodes.size(); ++i) {
    const bvh::BinaryNode& x = parallel.nodes[i];
    const bvh::BinaryNode& y = serial.nodes[i];
    differences += x.bounds.lo != y.bounds.lo || x.bounds.hi != y.bounds.hi || x.count != y.count ||
                   x.first != y.first || (!x.is_leaf() && x.right != y.right);
  }
  EXPECT_EQ(differences, 0);
}

TEST(MortonBuilder, RefusesWhatTheBinnedBuilderRefuses) {
  const std::vector<Bounds3> boxes = boxes_of(random_soup(10, 1));
  EXPECT_THROW(build(boxes, 0), std::invalid_argument);
  EXPECT_THROW(build(boxes, bvh::kMaxLeafSize + 1), std::invalid_argument);
}

}  // namespace
}  // namespace tritrace
