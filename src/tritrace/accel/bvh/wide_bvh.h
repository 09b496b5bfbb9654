// WideBvh: the traversal layout. Eight children per node with their boxes as structure of arrays
// (one AVX register per bound), and leaves of up to eight triangles stored as one SIMD block of
// their exact vertices. Made from the binary reference tree of binned_sah_builder.h.
#pragma once

#include <cstdint>
#include <vector>

#include "tritrace/accel/bvh/binned_sah_builder.h"
#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/huge_page_allocator.h"

namespace tritrace::bvh {

inline constexpr int kWidth = 8;
// A child reference with this bit set names a triangle block (a leaf); otherwise a node.
inline constexpr uint32_t kLeafBit = 0x80000000u;
inline constexpr uint32_t kEmptyChild = 0xFFFFFFFFu;

// Both traversals (single-ray and packet) scale far slab distances by 1 + 2 gamma(3), after Ize,
// "Robust BVH Ray Traversal" (JCGT 2013), so rounding can only make a box look bigger.
inline constexpr float kGamma3 = 3.0f * 0x1p-24f / (1.0f - 3.0f * 0x1p-24f);
inline constexpr float kFarScale = 1.0f + 2.0f * kGamma3;
// The builder bounds the binary depth by 64 + log2(n); at most 7 stacked children per level.
inline constexpr int kStackSize = 1024;

// A kernel computes with the triangle relative to the ray origin, so its rounding grows with the
// origin's distance as well as with the scene's size: the watertight kernel's sheared vertices are
// within 6 eps (|o| + |p|) of exact (eps = 2^-24; |p| the largest vertex coordinate, |o| the
// origin's; Woop et al. 2013 sec. 3), so a ray it reports hitting a triangle passes within that
// distance of it on each axis. The triangle boxes carry the scene's share (2^-16 |p|,
// wide_bvh.cpp); the traversals grow every box by origin_padding on each side for the origin's
// share, 16 eps |o|, without touching the tree: they compute near slab distances from the origin
// moved by +pad along the direction and far ones from the origin moved back by pad. So a camera at
// 1e7 sees the same hits through the BVH as through brute force (tests/accel/bvh_test.cpp).
inline constexpr float kOriginPadding = 0x1p-20f;
inline float origin_padding(float largest_origin_coordinate) {
  return kOriginPadding * largest_origin_coordinate;
}

struct alignas(32) WideNode {
  // Per child: box bounds. Empty slots hold an inverted box (lo = +inf, hi = -inf) that no ray
  // hits.
  float lo_x[kWidth], hi_x[kWidth], lo_y[kWidth], hi_y[kWidth], lo_z[kWidth], hi_z[kWidth];
  uint32_t child[kWidth];
};
static_assert(sizeof(WideNode) == 224);

// Up to eight triangles, one per lane, as the mesh stores them: the vertices bit for bit (the
// watertight kernel needs shared vertices to be identical in neighbouring triangles, and v0 + e1
// is not always v1 in float). Möller–Trumbore takes its edges as v1 - v0 and v2 - v0, the same
// operation that made the mesh's e1 and e2, so it reads the same bits. Padding lanes hold NaN
// vertices, which every kernel rejects, and prim kNoHit.
struct alignas(32) TriangleBlock {
  float vertex[3][3][kWidth];  // [corner][axis][lane]
  uint32_t prim[kWidth];       // the triangle's index in the mesh; kNoHit in padding lanes
};
static_assert(sizeof(TriangleBlock) == 320);

struct WideBvh {
  HugePageVector<WideNode> nodes;  // nodes[0] is the root; empty when the mesh is
  HugePageVector<TriangleBlock> blocks;
  size_t triangles = 0;

  size_t node_bytes() const { return nodes.size() * sizeof(WideNode); }
  size_t block_bytes() const { return blocks.size() * sizeof(TriangleBlock); }
};

// Builds the binary tree over the mesh's triangles, then collapses it into eight-wide nodes. Each
// triangle's box is padded for the kernels' rounding near the scene (kBoxPadding in wide_bvh.cpp);
// rounding that grows with the ray origin's distance is padded per ray by the traversals
// (origin_padding below).
[[nodiscard]] WideBvh build_wide_bvh(const TriangleMesh& mesh, const BuildConfig& config = {});

// The second half of build_wide_bvh: the binary tree (over `mesh`'s triangles, leaves of at most
// kMaxLeafSize) collapsed into eight-wide nodes. Of all ways to choose which binary nodes become
// wide nodes (each holding at most eight leaves or wide nodes), it takes one whose wide nodes'
// summed surface area, the SAH's expected number of node visits, is least.
[[nodiscard]] WideBvh collapse_binary_bvh(const BinaryBvh& tree, const TriangleMesh& mesh);

}  // namespace tritrace::bvh
