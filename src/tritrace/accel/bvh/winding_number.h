// The generalised winding number of a triangle mesh at a point (Jacobson, Kavan and Sorkine-
// Hornung, "Robust Inside-Outside Segmentation using Generalized Winding Numbers", SIGGRAPH 2013):
// the signed solid angle of every triangle seen from the point, summed and divided by 4 pi. It is
// 1 inside and 0 outside a closed, consistently oriented mesh (-1 inside when the mesh faces
// inward), and degrades gracefully on meshes with holes, which is why the signed distance and
// occupancy queries decide inside by it (|w| > 1/2) rather than by the sign of one nearest
// triangle.
//
// Evaluated hierarchically over the wide BVH after Barill, Dickson, Schmidt, Levin and Jacobson,
// "Fast Winding Numbers for Soups and Clouds" (SIGGRAPH 2018): a subtree whose triangles all lie
// within radius r of their area-weighted centre c, seen from farther than kFarRatio * r, counts as
// its Taylor expansion about c to second order (the dipole of its summed area vectors plus the
// first moment of those area vectors); every other triangle counts exactly, by the solid angle of
// Van Oosterom and Strackee, "The Solid Angle of a Plane Triangle" (IEEE TBME 1983), in double.
// So points near the surface, where the answer flips between 0 and 1, get the exact sum of their
// near triangles, and far ones an error of order (r / distance)^3 per subtree.
#pragma once

#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/huge_page_allocator.h"

namespace tritrace::bvh {

// Barill et al.'s beta: a subtree is approximated when the point is farther than this many of its
// radii from its centre. They report 2 as accurate enough for inside tests with a second-order
// expansion.
inline constexpr float kFarRatio = 2.0f;

// Per wide node, per child slot: the child subtree's expansion, as structure of arrays.
struct alignas(32) WindingSlots {
  float cx[kWidth], cy[kWidth], cz[kWidth];  // area-weighted centre of the triangles
  float nx[kWidth], ny[kWidth], nz[kWidth];  // summed area vectors, cross(v1 - v0, v2 - v0) / 2
  // Sum over triangles of area_vector_i * (centroid - centre)_j, row-major (i, j).
  float m[9][kWidth];
  float far2[kWidth];  // (kFarRatio * radius)^2; +inf in empty slots, which are never expanded
};

class WindingNumber {
 public:
  WindingNumber() = default;
  // The expansions of every subtree of `tree` (built over `mesh`), bottom up; subtrees are
  // expanded beyond far_ratio radii (kFarRatio by default), and with second-order terms unless
  // first_order_only (for measuring what the second order buys).
  WindingNumber(const WideBvh& tree, const TriangleMesh& mesh, float far_ratio = kFarRatio,
                bool first_order_only = false);

  // The winding number of the mesh at `query`, its triangles oriented by (v0, v1, v2) (positive
  // inside for counter-clockwise triangles seen from outside). 0 for an empty mesh.
  [[nodiscard]] double at(const WideBvh& tree, const glm::vec3& query) const;
  // Whether |winding number| > 1/2 at each query, out[i] = 1 or 0, over all cores.
  void inside(const WideBvh& tree, std::span<const glm::vec3> queries,
              std::span<uint8_t> out) const;

 private:
  HugePageVector<WindingSlots> slots_;  // slots_[n] for tree.nodes[n]
};

// The exact signed solid angle of triangle (a, b, c) seen from p, divided by 4 pi, in double.
[[nodiscard]] double triangle_winding(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                      const glm::dvec3& c);

}  // namespace tritrace::bvh
