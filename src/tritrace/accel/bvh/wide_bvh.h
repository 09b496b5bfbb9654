// WideBvh: the traversal layout. Eight children per node with their boxes as structure of arrays
// (one AVX register per bound), and leaves of up to eight triangles stored as one SIMD block in the
// kernels' (v0, e1, e2) form. Made from the binary reference tree of binned_sah_builder.h.
#pragma once

#include <cstdint>
#include <vector>

#include "tritrace/accel/bvh/binned_sah_builder.h"
#include "tritrace/geometry/triangle_mesh.h"

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

struct alignas(32) WideNode {
  // Per child: box bounds. Empty slots hold an inverted box (lo = +inf, hi = -inf) that no ray
  // hits.
  float lo_x[kWidth], hi_x[kWidth], lo_y[kWidth], hi_y[kWidth], lo_z[kWidth], hi_z[kWidth];
  uint32_t child[kWidth];
};
static_assert(sizeof(WideNode) == 224);

struct alignas(32) TriangleBlock {
  float v0x[kWidth], v0y[kWidth], v0z[kWidth];
  float e1x[kWidth], e1y[kWidth], e1z[kWidth];
  float e2x[kWidth], e2y[kWidth], e2z[kWidth];
  uint32_t prim[kWidth];  // the triangle's index in the mesh; kNoHit in padding lanes
};
static_assert(sizeof(TriangleBlock) == 320);

struct WideBvh {
  std::vector<WideNode> nodes;  // nodes[0] is the root; empty when the mesh is
  std::vector<TriangleBlock> blocks;
  size_t triangles = 0;

  size_t node_bytes() const { return nodes.size() * sizeof(WideNode); }
  size_t block_bytes() const { return blocks.size() * sizeof(TriangleBlock); }
};

// Builds the binary tree over the mesh's triangles, then collapses it into eight-wide nodes. The
// triangle boxes are widened by one float step so that they contain the exact triangle, whose
// vertices v0 + e1 and v0 + e2 the kernels never round.
[[nodiscard]] WideBvh build_wide_bvh(const TriangleMesh& mesh, const BuildConfig& config = {});

}  // namespace tritrace::bvh
