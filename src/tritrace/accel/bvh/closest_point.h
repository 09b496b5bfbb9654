// Closest points on a mesh: a best-first traversal of the eight-wide BVH (nearest child first,
// the others on a stack sorted by their boxes' distance, subtrees pruned once their box is
// farther than the best triangle so far), with the exact point/triangle distance of
// geometry/point_triangle_distance.h at the leaves, so that the answer is brute force's.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <limits>
#include <span>

#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/hit.h"
#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace::bvh {

struct ClosestPoint {
  glm::vec3 point{0.0f};  // on the mesh, rounded from double
  // |point - query| computed in double, then rounded; +inf when nothing was found (empty mesh,
  // non-finite query).
  float distance = std::numeric_limits<float>::infinity();
  uint32_t prim = kNoHit;  // the triangle's index in the mesh
  // Barycentrics: point = (1 - u - v) v0 + u v1 + v v2 of triangle `prim` as the mesh stores it.
  float u = 0.0f, v = 0.0f;
};

// The point of `mesh` nearest to `query` (`tree` built over `mesh`; the vertices are read from its
// blocks, except for blocks lanes whose corners are all equal, read from `mesh`, which is how
// GeometrySet's tree holds zero-area triangles). Among triangles at exactly
// the same distance (in double) the one with the lowest index wins, as in a brute-force loop.
[[nodiscard]] ClosestPoint closest_point(const WideBvh& tree, const TriangleMesh& mesh,
                                         const glm::vec3& query);

// closest_point for every query, out[i] for queries[i], over all cores of the current TBB arena.
void closest_points(const WideBvh& tree, const TriangleMesh& mesh,
                    std::span<const glm::vec3> queries, std::span<ClosestPoint> out);

// The reference: every triangle tested, in order. For tests and tiny meshes.
[[nodiscard]] ClosestPoint closest_point_brute_force(const TriangleMesh& mesh,
                                                     const glm::vec3& query);

}  // namespace tritrace::bvh
