// Smooth shading with interpolated vertex normals: the shading normal at a hit, and the origin
// shift that keeps low-poly spheres free of a faceted, black shadow terminator.
#pragma once

#include <cstddef>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace {

// The mesh's interpolated shading normal at barycentrics (u, v), turned to the side of the
// geometric normal `ng` (a vertex normal may disagree with the winding, or the interpolation
// may cross the surface at a sharp crease).
inline glm::vec3 oriented_shading_normal(const TriangleMesh& mesh, size_t tri, float u, float v,
                                         glm::vec3 ng) {
  const glm::vec3 ns = mesh.shading_normal(tri, u, v);
  return glm::dot(ns, ng) < 0.0f ? -ns : ns;
}

// Where secondary rays start on a smooth-shaded triangle: the hit point x (barycentrics u, v) moved
// onto the curved surface the vertex normals describe, after Hanika, "Hacking the Shadow
// Terminator" (Ray Tracing Gems II, 2021, chapter 4): x is projected onto each corner's tangent
// plane where it lies below it, and the projections are blended with the barycentrics. On a convex
// mesh the facets lie inside that curved surface, so a ray leaving it on the shading normal's side
// (even one that points below its own facet's plane, which the shading normal allows near the
// terminator) clears its own and the neighbouring facets instead of being blocked by them; where
// the mesh is concave (x above every tangent plane) x stays. The normals are taken on the side
// `side` (a unit vector on the side the ray leaves to); the result is x plus a vector that never
// points below that side's plane of the corner normals.
inline glm::vec3 terminator_safe_point(const TriangleMesh& mesh, size_t tri, float u, float v,
                                       glm::vec3 x, glm::vec3 side) {
  const glm::vec3* n = &mesh.corner_normals()[3 * tri];
  const float w[3] = {1.0f - u - v, u, v};
  glm::vec3 shift(0.0f);
  for (int k = 0; k < 3; ++k) {
    const glm::vec3 nk = glm::dot(n[k], side) < 0.0f ? -n[k] : n[k];
    const float below = glm::dot(x - mesh.vertex(tri, k), nk);
    if (below < 0.0f) shift -= (w[k] * below) * nk;
  }
  return x + shift;
}

}  // namespace tritrace
