// A binary BVH built top-down with the binned surface area heuristic of Wald, "On fast
// Construction of SAH-based Bounding Volume Hierarchies" (IEEE RT 2007), in parallel with TBB. It
// is the reference tree from which the wide, SIMD-friendly layout is made (wide_bvh.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "tritrace/huge_page_allocator.h"
#include "tritrace/math/bounds.h"

namespace tritrace::bvh {

// The most primitives a leaf may hold: the wide BVH stores a leaf as one eight-lane triangle block
// (wide_bvh.h), which has no room for a ninth.
inline constexpr uint32_t kMaxLeafSize = 8;

// How the binary tree is made: the binned SAH (the tree to trace many rays through), or Morton
// codes (morton_builder.h: faster to build on big meshes, slower to trace).
enum class BuildMethod { kBinnedSah, kMorton };

struct BuildConfig {
  BuildMethod method = BuildMethod::kBinnedSah;
  int bins = 16;  // clamped to [2, 32]; binned SAH only
  // Leaves hold at most this many primitives, 1 to kMaxLeafSize.
  uint32_t max_leaf_size = kMaxLeafSize;
  // The SAH prices a leaf (these and the settings below are the binned SAH's) per started block of
  // `block_size` primitives (at least 1), since a SIMD block costs the same whether it holds one
  // triangle or eight.
  uint32_t block_size = 8;
  float traversal_cost = 1.0f;  // one node visit
  float block_cost = 1.2f;      // one block of triangle tests, relative to a node visit
  // Ranges at least this large are binned with a parallel reduction and split in parallel tasks.
  uint32_t parallel_threshold = 1u << 14;
};

// The configuration make_accel builds with for a mesh of `triangles` triangles. Small meshes price
// a leaf per triangle (block_size 1), not per block of eight: the SAH then splits them into small
// leaves with tight boxes, so rays test fewer triangles, at the cost of partly filled blocks. That
// speeds up both integrators on a small mesh such as the 30-triangle lab box, but gains nothing on
// a big one and multiplies its leaf memory (docs/PERFORMANCE.md, "Fine leaves for small meshes");
// so only meshes below kFineLeavesBelow triangles, where that memory is at most a few MiB, get
// fine leaves.
inline constexpr size_t kFineLeavesBelow = size_t{1} << 14;
inline BuildConfig default_build_config(size_t triangles) {
  BuildConfig config;
  if (triangles < kFineLeavesBelow) config.block_size = 1;
  return config;
}

// The build of a second tree that BvhAccel keeps for a small mesh's incoherent closest-hit queries
// (the path tracer's bounce rays): `config` (fine leaves, priced per triangle) with a triangle
// priced at 0.15 of its cost, so that leaves hold more triangles and a ray takes fewer steps.
// The path tracer's bounce rays ran 1.25x faster through it on scenes/sky.json (single rays) and
// 1.35x on cornell-area (incoherent packets) at 0.25, the same on scenes/glass.json, and 4% faster
// again on sky.json at 0.15; the lab's coherent packets were slower on such a tree, so they keep
// the fine one, and shadow rays take whichever tree a sample of them chose
// (BvhAccel::occluded_tree; docs/PERFORMANCE.md, "Single rays on small trees" and "Shadow rays on
// the tree a sample of them chose", issue 27).
inline constexpr float kIncoherentClosestCostScale = 0.15f;
inline bool wants_incoherent_closest_tree(const BuildConfig& config) {
  return config.block_size == 1 && config.method == BuildMethod::kBinnedSah;
}
inline BuildConfig incoherent_closest_config(const BuildConfig& config) {
  BuildConfig coarse = config;
  coarse.block_cost *= kIncoherentClosestCostScale;
  return coarse;
}

struct BinaryNode {
  Bounds3 bounds;
  uint32_t count = 0;  // > 0: leaf of prim_index[first, first + count)
  uint32_t first = 0;  // leaf: first index; inner: index of the left child
  uint32_t right = 0;  // inner: index of the right child
  bool is_leaf() const { return count > 0; }
};

// On huge pages, as every array of a big build: at ten million primitives these are 150 MiB.
struct BinaryBvh {
  HugePageVector<BinaryNode> nodes;     // nodes[0] is the root; empty for no primitives
  HugePageVector<uint32_t> prim_index;  // leaves index into this permutation of the primitives
};

// Throws std::invalid_argument when `config` cannot be built (max_leaf_size 0 or above
// kMaxLeafSize, block_size 0) or `count` primitives cannot be indexed in 32 bits.
void check_build_config(size_t count, const BuildConfig& config);

// Builds over the primitives' bounding boxes. Boxes must be non-empty and finite; boxes at any
// finite magnitude (surface areas that overflow float, extents too small for 1 / extent) still
// give a valid tree. Throws std::invalid_argument when max_leaf_size is 0 or above kMaxLeafSize,
// or block_size is 0.
[[nodiscard]] BinaryBvh build_binned_sah(std::span<const Bounds3> prim_bounds,
                                         const BuildConfig& config = {});

// Writes the boxes of primitives [begin, end) to out[0], ..., out[end - begin - 1]; called from
// several threads at once, on disjoint ranges of at most kBoxBatch primitives.
using BoxSource = std::function<void(size_t begin, size_t end, Bounds3* out)>;
inline constexpr size_t kBoxBatch = 1024;

// The same build over `count` primitives whose boxes come from `boxes`, without an array of them
// (at ten million triangles that array would be 240 MB of fresh pages, and the first touch of
// fresh pages is slow, on a virtual machine especially; docs/PERFORMANCE.md, "A faster binned SAH
// build").
[[nodiscard]] BinaryBvh build_binned_sah(size_t count, const BoxSource& boxes,
                                         const BuildConfig& config = {});

}  // namespace tritrace::bvh
