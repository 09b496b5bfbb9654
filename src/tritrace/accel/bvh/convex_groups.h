// Convex groups: sets of triangles that a ray leaving one of them towards its outer side cannot hit
// again, and the subtrees of a WideBvh that hold only one such set, so that a bounce or shadow ray
// leaving a convex mesh skips it.
//
// If every vertex of a group G lies in the closed back half-space of every triangle T of G
// (sigma dot(n_T, v - v0_T) <= 0 for one sign sigma for the whole group: the surface of a convex
// polytope, or part of it, consistently oriented), then G lies in that half-space of each of its
// triangles, and a ray that starts on T's front side (an origin moved off T towards
// sigma n_T, as the path tracer's are) heading into it (sigma dot(d, n_T) > 0) stays in the open
// front half-space for t > 0: it cannot hit any triangle of G. A group all of whose triangles lie
// in one plane holds for both signs.
#pragma once

#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace::bvh {

inline constexpr uint32_t kNoGroup = 0xFFFFFFFFu;

// Components of more triangles than this are not tested: the test compares every vertex with every
// triangle's plane (16M comparisons at this size, about 20 ms; a non-convex mesh usually fails
// within its first triangles).
inline constexpr size_t kMaxConvexGroupTriangles = 4096;

// A triangle's part in a group: its unit normal turned to the group's outer side (sigma n_T, from
// the vertices in double precision), and the group; for a triangle in no group (or of zero area), a
// zero normal and kNoGroup.
struct ConvexFace {
  float n[3] = {0.0f, 0.0f, 0.0f};
  uint32_t group = kNoGroup;
};

struct ConvexGroups {
  std::vector<ConvexFace> faces;  // one per triangle
  std::vector<uint8_t> flat;      // per group: 1 when all its triangles lie in one plane
  size_t count() const { return flat.size(); }
};

// The groups of `mesh`: its connected components (triangles that share a vertex position, bit for
// bit, are connected), each one group when convex as above. The test runs in double precision and
// lets a vertex lie up to 8 float ULPs of the component's largest coordinate in front of a plane
// (the two halves of a flat quad stored as floats are coplanar only up to rounding); so a ray
// leaving a group that passes only within that tolerance can miss a hit on its own group within
// about tolerance / cos(angle to the plane) of its origin, a self-intersection.
[[nodiscard]] ConvexGroups find_convex_groups(const TriangleMesh& mesh,
                                              size_t max_triangles = kMaxConvexGroupTriangles);

// Per node of a wide tree, per child: the group of every triangle below that child, or kNoGroup
// when they are not all of one group (or the slot is empty).
struct alignas(32) ChildGroups {
  uint32_t group[kWidth];
};
[[nodiscard]] std::vector<ChildGroups> child_groups(const WideBvh& tree,
                                                    std::span<const ConvexFace> faces);

// The group a ray in direction `dir` leaving triangle `prim` (kNoHit: none) may skip, or kNoGroup:
// the triangle's group when the ray heads into its outer side, by a cosine of at least
// kSkipMinCosine (grazing rays, where rounding of the normal could turn the sign, skip nothing).
inline constexpr float kSkipMinCosine = 1e-3f;
[[gnu::always_inline]] inline uint32_t skip_group(std::span<const ConvexFace> faces,
                                                  std::span<const uint8_t> flat, uint32_t prim,
                                                  const float* dir) {
  if (prim >= faces.size()) return kNoGroup;
  const ConvexFace& f = faces[prim];
  if (f.group == kNoGroup) return kNoGroup;
  // A flat group skips both ways: its cosine's sign bit is cleared. Without a branch, which was
  // a coin toss where rays leave both flat and curved groups (scenes/sky.json's ground and
  // spheres).
  const float signed_cosine = f.n[0] * dir[0] + f.n[1] * dir[1] + f.n[2] * dir[2];
  const uint32_t keep = 0xffffffffu >> (flat[f.group] != 0 ? 1 : 0);
  const float cosine = std::bit_cast<float>(std::bit_cast<uint32_t>(signed_cosine) & keep);
  // |d|_1 >= |d|_2: the bound only grows with it.
  const float length = (dir[0] < 0.0f ? -dir[0] : dir[0]) + (dir[1] < 0.0f ? -dir[1] : dir[1]) +
                       (dir[2] < 0.0f ? -dir[2] : dir[2]);
  return cosine > kSkipMinCosine * length ? f.group : kNoGroup;
}

}  // namespace tritrace::bvh
