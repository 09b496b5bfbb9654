// The binned SAH builder on inputs at the edges of float: centroid extents so small that 1 / extent
// overflows, triangles that all share one centroid, coordinates whose surface areas overflow; and
// the leaf-size limit of the wide BVH's eight-lane blocks. Trees are checked structurally and, as
// BVHs, against the brute-force oracle.
#include "tritrace/accel/bvh/binned_sah_builder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/scene/procedural.h"

namespace tritrace {
namespace {

using bvh::BinaryBvh;
using bvh::BuildConfig;

// The limit is the wide BVH's block width, which the builder cannot include (it is the lower
// layer).
static_assert(bvh::kMaxLeafSize == static_cast<uint32_t>(bvh::kWidth));

bool finite(const Bounds3& b) {
  return std::isfinite(b.lo.x) && std::isfinite(b.lo.y) && std::isfinite(b.lo.z) &&
         std::isfinite(b.hi.x) && std::isfinite(b.hi.y) && std::isfinite(b.hi.z);
}

// Every primitive in exactly one leaf, leaves of 1 to max_leaf primitives, every box finite and
// containing its children's boxes (a leaf's: its primitives').
void check_tree(const BinaryBvh& tree, std::span<const Bounds3> boxes, uint32_t max_leaf) {
  ASSERT_FALSE(tree.nodes.empty());
  ASSERT_EQ(tree.prim_index.size(), boxes.size());
  std::vector<int> seen(boxes.size(), 0);
  std::vector<uint32_t> todo{0};
  size_t visited = 0;
  while (!todo.empty()) {
    const uint32_t i = todo.back();
    todo.pop_back();
    ASSERT_LT(i, tree.nodes.size());
    ++visited;
    const bvh::BinaryNode& n = tree.nodes[i];
    ASSERT_TRUE(finite(n.bounds)) << "node " << i;
    if (n.is_leaf()) {
      EXPECT_LE(n.count, max_leaf);
      ASSERT_LE(size_t{n.first} + n.count, tree.prim_index.size());
      for (uint32_t k = n.first; k < n.first + n.count; ++k) {
        const uint32_t p = tree.prim_index[k];
        ASSERT_LT(p, boxes.size());
        ++seen[p];
        EXPECT_TRUE(n.bounds.contains(boxes[p])) << "primitive " << p << " outside its leaf";
      }
      continue;
    }
    for (uint32_t c : {n.first, n.right}) {
      ASSERT_LT(c, tree.nodes.size());
      EXPECT_TRUE(n.bounds.contains(tree.nodes[c].bounds)) << "child " << c << " outside " << i;
      todo.push_back(c);
    }
  }
  EXPECT_EQ(visited, tree.nodes.size()) << "unreachable nodes";
  for (size_t p = 0; p < boxes.size(); ++p) EXPECT_EQ(seen[p], 1) << "primitive " << p;
}

// The primitives under node `i`.
std::vector<uint32_t> prims_under(const BinaryBvh& tree, uint32_t i) {
  std::vector<uint32_t> out, todo{i};
  while (!todo.empty()) {
    const bvh::BinaryNode& n = tree.nodes[todo.back()];
    todo.pop_back();
    if (n.is_leaf()) {
      out.insert(out.end(), tree.prim_index.begin() + n.first,
                 tree.prim_index.begin() + n.first + n.count);
    } else {
      todo.push_back(n.first);
      todo.push_back(n.right);
    }
  }
  return out;
}

std::vector<uint32_t> shuffled_indices(uint32_t n, uint32_t seed) {
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::shuffle(order.begin(), order.end(), std::mt19937(seed));
  return order;
}

// Rays from random points in a cube of half-size 1.5 * scale towards random points of random
// triangles; every third one a bounded segment that ends halfway, like a shadow ray.
std::vector<Ray> rays_at_triangles(const TriangleMesh& mesh, int n, float scale, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.5f, 1.5f), unit(0.0f, 1.0f);
  std::uniform_int_distribution<size_t> tri(0, mesh.size() - 1);
  std::vector<Ray> rays;
  for (int i = 0; i < n; ++i) {
    const size_t t = tri(rng);
    const float a = unit(rng), b = unit(rng) * (1.0f - a);
    const glm::vec3 target = mesh.v0()[t] + a * mesh.e1(t) + b * mesh.e2(t);
    Ray r;
    r.origin = glm::vec3(pos(rng), pos(rng), pos(rng)) * scale;
    const glm::vec3 d = target - r.origin;
    const float length = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    r.dir = d / length;
    if (i % 3 == 0) r.tmax = 0.5f * length;
    rays.push_back(r);
  }
  return rays;
}

// BvhAccel built with `config` returns the brute-force hits bit for bit, and the same occlusion,
// for every kernel. Returns the number of brute-force hits with the last kernel.
int expect_same_as_brute(const TriangleMesh& mesh, const std::vector<Ray>& rays,
                         const BuildConfig& config = {}) {
  int hits = 0;
  for (Kernel kernel : kAllKernels) {
    const BruteForceAccel brute(mesh, kernel);
    const BvhAccel accel(mesh, kernel, config);
    std::vector<Hit> want(rays.size()), got(rays.size());
    std::vector<uint8_t> want_occ(rays.size()), got_occ(rays.size());
    brute.intersect(rays, want);
    accel.intersect(rays, got);
    brute.occluded(rays, want_occ);
    accel.occluded(rays, got_occ);
    int mismatches = 0;
    hits = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      hits += want[i].found();
      const bool same = want[i].prim == got[i].prim && want[i].t == got[i].t &&
                        want[i].u == got[i].u && want[i].v == got[i].v && want_occ[i] == got_occ[i];
      if (!same && ++mismatches <= 5) {
        ADD_FAILURE() << kernel_name(kernel) << " ray " << i << ": brute prim " << want[i].prim
                      << " t " << want[i].t << " occ " << int(want_occ[i]) << ", bvh prim "
                      << got[i].prim << " t " << got[i].t << " occ " << int(got_occ[i]);
      }
    }
    EXPECT_EQ(mismatches, 0) << kernel_name(kernel);
  }
  return hits;
}

TEST(BinnedSahBuilder, RefusesLeavesLargerThanOneBlock) {
  const std::vector<Bounds3> boxes(20, Bounds3{glm::vec3(0.0f), glm::vec3(1.0f)});
  EXPECT_THROW((void)bvh::build_binned_sah(boxes, {.max_leaf_size = 9}), std::invalid_argument);
  EXPECT_THROW((void)bvh::build_binned_sah(boxes, {.max_leaf_size = 0}), std::invalid_argument);
  EXPECT_THROW((void)bvh::build_binned_sah(boxes, {.block_size = 0}), std::invalid_argument);
  try {
    (void)bvh::build_binned_sah(boxes, {.max_leaf_size = 16});
    ADD_FAILURE() << "max_leaf_size 16 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_leaf_size is 16"), std::string::npos) << e.what();
  }
  // Through the accel too: the wide BVH is built with the caller's config.
  TriangleMesh mesh;
  mesh.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0);
  EXPECT_THROW({ const BvhAccel accel(mesh, kDefaultKernel, {.max_leaf_size = 9}); },
               std::invalid_argument);
  check_tree(bvh::build_binned_sah(boxes, {.max_leaf_size = 8}), boxes, 8);
}

TEST(BinnedSahBuilder, EveryLeafSizeUpToEightKeepsTheBruteForceHits) {
  // Forty copies of a 2 x 2 grid cell at the same place: nothing separates them, so leaves are
  // filled up to the limit (and for the limit of 8, to all of its lanes).
  TriangleMesh mesh;
  for (int i = 0; i < 40; ++i) mesh.add({0, 0, 0}, {2, 0, 0}, {0, 2, 0}, 0);
  for (int i = 0; i < 200; ++i) {
    const float x = static_cast<float>(i % 20) * 0.3f - 3.0f, y = static_cast<float>(i / 20) * 0.3f;
    mesh.add({x, y, 1.0f}, {x + 0.25f, y, 1.0f}, {x, y + 0.25f, 1.1f}, 0);
  }
  std::vector<Bounds3> boxes(mesh.size());
  for (size_t i = 0; i < mesh.size(); ++i) boxes[i] = mesh.triangle_bounds(i);
  const std::vector<Ray> rays = rays_at_triangles(mesh, 3000, 4.0f, 1);
  for (uint32_t leaf : {1u, 3u, 8u}) {
    SCOPED_TRACE(leaf);
    const BinaryBvh tree = bvh::build_binned_sah(boxes, {.max_leaf_size = leaf});
    check_tree(tree, boxes, leaf);
    if (leaf == 8) {
      // The identical triangles cannot be split by any plane: some leaf holds eight of them.
      const bool full = std::any_of(tree.nodes.begin(), tree.nodes.end(),
                                    [](const bvh::BinaryNode& n) { return n.count == 8; });
      EXPECT_TRUE(full);
    }
    EXPECT_GT(expect_same_as_brute(mesh, rays, {.max_leaf_size = leaf}), 1000);
  }
}

// Centroids 0, 1, ..., 63 times the smallest denormal along z (flat boxes, the same in x and y):
// 16 / extent is inf in float, and (c - lo) * inf is NaN or inf, whose cast to int is undefined
// (the UBSan build of `make test-asan` checks float-cast-overflow). No plane separates them in
// float, so the builder halves the range, down to the leaf size asked for.
TEST(BinnedSahBuilder, DenormalCentroidExtentBuildsAValidTree) {
  constexpr float kTiny = std::numeric_limits<float>::denorm_min();
  constexpr uint32_t kCount = 64;
  const std::vector<uint32_t> order = shuffled_indices(kCount, 3);
  std::vector<Bounds3> boxes(kCount);
  for (uint32_t i = 0; i < kCount; ++i) {
    const float z = static_cast<float>(order[i]) * kTiny;
    boxes[i] = Bounds3{{-1.0f, -1.0f, z}, {1.0f, 1.0f, z}};
  }
  ASSERT_TRUE(std::isinf(16.0f / (63.0f * kTiny)));  // the case this test is for
  for (uint32_t leaf : {1u, 5u, 8u}) {
    SCOPED_TRACE(leaf);
    check_tree(bvh::build_binned_sah(boxes, {.max_leaf_size = leaf}), boxes, leaf);
  }
  // A tiny but normal extent is still split by position: 64 centroids 1e-30 apart.
  for (uint32_t i = 0; i < kCount; ++i) {
    const float z = static_cast<float>(order[i]) * 1e-30f;
    boxes[i] = Bounds3{{-1.0f, -1.0f, z}, {1.0f, 1.0f, z}};
  }
  const BinaryBvh tree = bvh::build_binned_sah(boxes);
  check_tree(tree, boxes, bvh::kMaxLeafSize);
  ASSERT_FALSE(tree.nodes[0].is_leaf());
  float left_max = -1.0f, right_min = 1.0f;
  for (uint32_t p : prims_under(tree, tree.nodes[0].first)) {
    left_max = std::max(left_max, boxes[p].lo.z);
  }
  for (uint32_t p : prims_under(tree, tree.nodes[0].right)) {
    right_min = std::min(right_min, boxes[p].lo.z);
  }
  EXPECT_LT(left_max, right_min) << "the root's split is not a plane along z";
}

// Two clusters at -1e30 and +1e30 along x, listed alternately: every box's surface area (about
// 1e50) overflows float. With costs compared as numbers the root separates the clusters; with
// inf against inf no split looks better and the range is halved by index, mixing them.
TEST(BinnedSahBuilder, HugeCoordinatesStillSplitByCost) {
  std::vector<Bounds3> boxes;
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> jitter(-1e27f, 1e27f);
  for (int i = 0; i < 400; ++i) {
    const float side = i % 2 == 0 ? -1e30f : 1e30f;
    const glm::vec3 c(side + jitter(rng), jitter(rng), jitter(rng));
    boxes.push_back(Bounds3{c - glm::vec3(1e25f), c + glm::vec3(1e25f)});
  }
  ASSERT_TRUE(std::isinf(boxes[0].area()));  // the case this test is for
  const BinaryBvh tree = bvh::build_binned_sah(boxes);
  check_tree(tree, boxes, bvh::kMaxLeafSize);
  ASSERT_FALSE(tree.nodes[0].is_leaf());
  for (uint32_t child : {tree.nodes[0].first, tree.nodes[0].right}) {
    const std::vector<uint32_t> prims = prims_under(tree, child);
    ASSERT_FALSE(prims.empty());
    const bool negative = boxes[prims[0]].lo.x < 0.0f;
    const auto other_side = std::count_if(
        prims.begin(), prims.end(), [&](uint32_t p) { return (boxes[p].lo.x < 0.0f) != negative; });
    EXPECT_EQ(other_side, 0) << "the root's children mix the two clusters";
  }
}

// Boxes reaching +-3e38: lo + hi overflows float for some, so a centroid taken as (lo + hi) / 2
// would be inf. The tree must still hold every box.
TEST(BinnedSahBuilder, BoxesNearTheFloatLimitBuild) {
  std::vector<Bounds3> boxes;
  for (int i = 0; i < 100; ++i) {
    const float x = (i % 2 == 0 ? 1.0f : -1.0f) * (3.0e38f - static_cast<float>(i) * 1e36f);
    boxes.push_back(Bounds3{{x * 0.9f, -1.0f, -1.0f}, {x, 1.0f + i, 1.0f}});
    if (x < 0.0f) std::swap(boxes.back().lo.x, boxes.back().hi.x);
  }
  ASSERT_TRUE(std::isinf(boxes[0].lo.x + boxes[0].hi.x));  // the case this test is for
  check_tree(bvh::build_binned_sah(boxes), boxes, bvh::kMaxLeafSize);
  check_tree(bvh::build_binned_sah(boxes, {.max_leaf_size = 1}), boxes, 1);
}

// Triangles (p, -p, q) with |q| <= |p| in every coordinate: their boxes are [-|p|, |p|], so all
// centroids are exactly the origin and no plane separates them, yet the boxes differ in size.
TEST(BinnedSahBuilder, TrianglesWithOneCommonCentroidKeepTheBruteForceHits) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> size(0.05f, 1.0f), unit(-1.0f, 1.0f);
  TriangleMesh mesh;
  for (int i = 0; i < 1500; ++i) {
    const glm::vec3 p(size(rng), size(rng), size(rng));
    const glm::vec3 q(p.x * unit(rng), p.y * unit(rng), p.z * unit(rng));
    mesh.add(p, -p, q, 0);
  }
  for (size_t i = 0; i < mesh.size(); ++i) {
    ASSERT_EQ(mesh.triangle_bounds(i).centre(), glm::vec3(0.0f));
  }
  EXPECT_GT(expect_same_as_brute(mesh, rays_at_triangles(mesh, 2000, 2.0f, 6)), 1000);
}

// Visits the subtrees of `a` and `b` at nodes i and j together: the same shape, boxes and leaf
// ranges. Node numbers may differ (tasks take them in any order); the permutation may not.
void expect_same_subtree(const BinaryBvh& a, uint32_t i, const BinaryBvh& b, uint32_t j,
                         int& differences) {
  const bvh::BinaryNode& x = a.nodes[i];
  const bvh::BinaryNode& y = b.nodes[j];
  const bool same = x.is_leaf() == y.is_leaf() && x.bounds.lo == y.bounds.lo &&
                    x.bounds.hi == y.bounds.hi &&
                    (!x.is_leaf() || (x.first == y.first && x.count == y.count));
  if (!same) {
    ++differences;
    return;
  }
  if (!x.is_leaf()) {
    expect_same_subtree(a, x.first, b, y.first, differences);
    expect_same_subtree(a, x.right, b, y.right, differences);
  }
}

// The parallel build (binning by parallel reduction, subtrees in tasks: here from 64 primitives
// up, so tasks run everywhere) must make exactly the tree of the serial build: bins are merged
// with min, max and integer sums, which give the same result in any order.
TEST(BinnedSahBuilder, ParallelBuildMakesTheSerialTree) {
  const TriangleMesh mesh = make_terrain_scene(60000).mesh;
  std::vector<Bounds3> boxes(mesh.size());
  for (size_t i = 0; i < mesh.size(); ++i) boxes[i] = mesh.triangle_bounds(i);
  const BinaryBvh serial =
      bvh::build_binned_sah(boxes, {.parallel_threshold = std::numeric_limits<uint32_t>::max()});
  const BinaryBvh parallel = bvh::build_binned_sah(boxes, {.parallel_threshold = 64});
  check_tree(parallel, boxes, bvh::kMaxLeafSize);
  ASSERT_EQ(parallel.nodes.size(), serial.nodes.size());
  EXPECT_TRUE(parallel.prim_index == serial.prim_index);
  int differences = 0;
  expect_same_subtree(parallel, 0, serial, 0, differences);
  EXPECT_EQ(differences, 0);
}

// A plain restatement of the build's rules, the oracle for the vectorised builder: per node, the
// centroid bounds; 16 bins per axis over them (bin = trunc(min((c - lo) * 16 / extent, 15)), 0 for
// a NaN or non-positive value, no split on an axis whose 16 / extent is not a finite float); the
// SAH sweep in float (leaf cost 1.2 per started block of 8, area 2 (xy + yz + zx)); a leaf when at
// most 8 primitives and not cheaper split (traversal cost 1); otherwise the cheapest split,
// partitioned in any order, and halves when a split leaves a side empty.
class ReferenceSah {
 public:
  explicit ReferenceSah(std::span<const Bounds3> boxes) : boxes_(boxes) {}

  struct Node {
    Bounds3 bounds;
    std::vector<uint32_t> leaf;  // sorted primitives of a leaf
    std::unique_ptr<Node> left, right;
  };

  std::unique_ptr<Node> build(std::vector<uint32_t> prims) const {
    auto node = std::make_unique<Node>();
    Bounds3 cb = Bounds3::empty();
    node->bounds = Bounds3::empty();
    for (uint32_t p : prims) {
      node->bounds.extend(boxes_[p]);
      cb.extend(boxes_[p].centre());
    }
    const auto blocks_cost = [](size_t n) { return 1.2f * static_cast<float>((n + 7) / 8); };
    const auto area = [](const Bounds3& b) {
      const glm::vec3 e = b.hi - b.lo;
      return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
    };
    constexpr int kBins = 16;
    int best_axis = -1, best_bin = 0;
    float best_cost = std::numeric_limits<float>::infinity();
    std::array<float, 3> scale{};
    for (int a = 0; a < 3 && prims.size() > 1; ++a) {
      const double s = kBins / (double{cb.hi[a]} - cb.lo[a]);
      if (!(s > 0.0 && s <= double{std::numeric_limits<float>::max()})) continue;
      scale[a] = static_cast<float>(s);
      std::array<Bounds3, kBins> bin;
      std::array<size_t, kBins> count{};
      bin.fill(Bounds3::empty());
      for (uint32_t p : prims) {
        const int b = bin_of(boxes_[p].centre()[a], cb.lo[a], scale[a]);
        bin[b].extend(boxes_[p]);
        ++count[b];
      }
      for (int split = 1; split < kBins; ++split) {
        Bounds3 l = Bounds3::empty(), r = Bounds3::empty();
        size_t nl = 0, nr = 0;
        for (int b = 0; b < kBins; ++b) {
          (b < split ? l : r).extend(bin[b]);
          (b < split ? nl : nr) += count[b];
        }
        if (nl == 0 || nr == 0) continue;
        const float cost = area(l) * blocks_cost(nl) + area(r) * blocks_cost(nr);
        if (cost < best_cost) best_cost = cost, best_axis = a, best_bin = split;
      }
    }
    const glm::dvec3 e = glm::dvec3(node->bounds.hi) - glm::dvec3(node->bounds.lo);
    const double parent_area = 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x);
    const double split_cost = 1.0 + (parent_area > 0.0 ? best_cost / parent_area : 0.0);
    if (prims.size() <= 8 && (best_axis < 0 || !(blocks_cost(prims.size()) > split_cost))) {
      node->leaf = prims;
      std::sort(node->leaf.begin(), node->leaf.end());
      return node;
    }
    std::vector<uint32_t> left, right;
    for (uint32_t p : prims) {
      const bool goes_left =
          best_axis >= 0 &&
          bin_of(boxes_[p].centre()[best_axis], cb.lo[best_axis], scale[best_axis]) < best_bin;
      (goes_left ? left : right).push_back(p);
    }
    if (left.empty() || right.empty()) {
      // (Only when every centroid coincides; the order of the halves is then the builder's own.)
      ADD_FAILURE() << "the reference has no binned split for " << prims.size() << " primitives";
      return node;
    }
    node->left = build(std::move(left));
    node->right = build(std::move(right));
    return node;
  }

 private:
  static int bin_of(float c, float lo, float scale) {
    const float x = (c - lo) * scale;
    if (!(x > 0.0f)) return 0;
    return static_cast<int>(std::min(x, 15.0f));
  }
  std::span<const Bounds3> boxes_;
};

// Nodes of `tree` under `i` that differ from the reference's `ref`, in bounds, shape or the set of
// primitives of a leaf.
int differences_from(const BinaryBvh& tree, uint32_t i, const ReferenceSah::Node& ref) {
  const bvh::BinaryNode& n = tree.nodes[i];
  if (!(n.bounds.lo == ref.bounds.lo && n.bounds.hi == ref.bounds.hi)) return 1;
  if (n.is_leaf() != !ref.leaf.empty()) return 1;
  if (n.is_leaf()) {
    std::vector<uint32_t> prims(tree.prim_index.begin() + n.first,
                                tree.prim_index.begin() + n.first + n.count);
    std::sort(prims.begin(), prims.end());
    return prims == ref.leaf ? 0 : 1;
  }
  return differences_from(tree, n.first, *ref.left) + differences_from(tree, n.right, *ref.right);
}

// The vectorised builder (references moved with the partition, SSE binning, its own sweep) makes
// the reference's tree node for node, serial and parallel, on a terrain and on a random soup.
TEST(BinnedSahBuilder, MakesTheTreeOfAPlainRestatementOfItsRules) {
  std::vector<std::vector<Bounds3>> inputs;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> pos(-1.0f, 1.0f), size(0.001f, 0.4f);
  TriangleMesh soup;
  for (int i = 0; i < 5000; ++i) {
    const glm::vec3 c(pos(rng), pos(rng), pos(rng));
    const float s = size(rng);
    soup.add(c, c + s * glm::vec3(pos(rng), pos(rng), pos(rng)),
             c + s * glm::vec3(pos(rng), pos(rng), pos(rng)), 0);
  }
  for (const TriangleMesh& mesh : {make_terrain_scene(20000).mesh, soup}) {
    std::vector<Bounds3>& boxes = inputs.emplace_back(mesh.size());
    for (size_t i = 0; i < mesh.size(); ++i) boxes[i] = mesh.triangle_bounds(i);
  }
  for (const std::vector<Bounds3>& boxes : inputs) {
    std::vector<uint32_t> all(boxes.size());
    std::iota(all.begin(), all.end(), 0u);
    const auto ref = ReferenceSah(boxes).build(all);
    for (const uint32_t threshold : {std::numeric_limits<uint32_t>::max(), 256u}) {
      const BinaryBvh tree = bvh::build_binned_sah(boxes, {.parallel_threshold = threshold});
      check_tree(tree, boxes, bvh::kMaxLeafSize);
      EXPECT_EQ(differences_from(tree, 0, *ref), 0)
          << boxes.size() << " boxes, tasks from " << threshold;
    }
  }
}

// A random soup around the origin, where the rays go, plus `count` far triangles made by
// `far(i)`.
template <typename Far>
TriangleMesh soup_with_far_triangles(int count, Far far) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> pos(-1.0f, 1.0f), size(0.01f, 0.3f);
  TriangleMesh mesh;
  for (int i = 0; i < 1500; ++i) {
    const glm::vec3 c(pos(rng), pos(rng), pos(rng));
    const float s = size(rng);
    mesh.add(c, c + s * glm::vec3(pos(rng), pos(rng), pos(rng)),
             c + s * glm::vec3(pos(rng), pos(rng), pos(rng)), 0);
  }
  for (int i = 0; i < count; ++i) {
    const std::array<glm::vec3, 3> v = far(i);
    mesh.add(v[0], v[1], v[2], 0);
  }
  return mesh;
}

// Far triangles at 1e19, each with a box area that float holds, but the boxes of the upper nodes
// have areas above FLT_MAX (about 3.4e38), where float SAH costs were inf.
TEST(BinnedSahBuilder, SceneWhoseNodeAreasOverflowFloatKeepsTheBruteForceHits) {
  const TriangleMesh mesh = soup_with_far_triangles(40, [](int i) {
    const glm::vec3 c = glm::vec3(i % 2 ? 1.0f : -1.0f, i % 4 < 2 ? 1.0f : -1.0f, i % 3 - 1.0f) *
                        (1e19f + 1e17f * static_cast<float>(i));
    return std::array<glm::vec3, 3>{c, c + glm::vec3(1e16f, 0, 0), c + glm::vec3(0, 1e16f, 1e15f)};
  });
  ASSERT_TRUE(std::isinf(mesh.bounds().area()));  // the case this test is for
  for (size_t i = 0; i < mesh.size(); ++i) {
    ASSERT_TRUE(std::isfinite(mesh.triangle_bounds(i).area())) << i;
  }
  EXPECT_GT(expect_same_as_brute(mesh, rays_at_triangles(mesh, 2000, 1.0f, 8)), 1000);
}

// Far triangles at 1e30 whose own box areas overflow float.
TEST(BinnedSahBuilder, SceneWithTrianglesWhoseAreasOverflowKeepsTheBruteForceHits) {
  const TriangleMesh mesh = soup_with_far_triangles(40, [](int i) {
    const float s = 1e30f * (1.0f + 0.01f * static_cast<float>(i));
    const glm::vec3 c(i % 2 ? s : -s, 0.5f * s, i % 3 == 0 ? s : -s);
    return std::array<glm::vec3, 3>{c, c + glm::vec3(s, 0, 0), c + glm::vec3(0, s, 0.5f * s)};
  });
  ASSERT_TRUE(std::isinf(mesh.triangle_bounds(mesh.size() - 1).area()));  // the case it is for
  EXPECT_GT(expect_same_as_brute(mesh, rays_at_triangles(mesh, 2000, 1.0f, 9)), 1000);
}

}  // namespace
}  // namespace tritrace
