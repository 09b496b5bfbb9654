// Smooth shading with interpolated vertex normals: the shading normal at a hit, and the origin
// shift that keeps low-poly spheres free of a faceted, black shadow terminator.
#pragma once

#include <cmath>
#include <cstddef>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// The interpolated shading normal at barycentrics (u, v) of a triangle with corners `c`, turned to
// the side of the geometric normal `ng` (a vertex normal may disagree with the winding, or the
// interpolation may cross the surface at a sharp crease); `ng` itself where the interpolated
// normal vanishes. TriangleMesh::shading_normal's arithmetic.
inline glm::vec3 oriented_shading_normal(const SmoothCorners& c, float u, float v, glm::vec3 ng) {
  const glm::vec3 s = (1.0f - u - v) * c.normal[0] + u * c.normal[1] + v * c.normal[2];
  const float len2 = glm::dot(s, s);
  const glm::vec3 ns = len2 > 0.0f && std::isfinite(len2) ? s * (1.0f / std::sqrt(len2)) : ng;
  return glm::dot(ns, ng) < 0.0f ? -ns : ns;
}

// The same for triangle `tri` of a mesh with vertex normals.
inline glm::vec3 oriented_shading_normal(const TriangleMesh& mesh, size_t tri, float u, float v,
                                         glm::vec3 ng) {
  const glm::vec3 ns = mesh.shading_normal(tri, u, v);
  return glm::dot(ns, ng) < 0.0f ? -ns : ns;
}

// The path tracer's one rule for shading normals, the same in every BSDF branch (Veach, "Robust
// Monte Carlo Methods for Light Transport Simulation", 1997, section 5.3; pbrt-v3's BSDF::f): the
// shading normal shades a direction only where it agrees with the geometric normal on which side
// of the surface that direction lies. wo on different sides of the two surfaces: the geometric
// normal shades instead. wi (a light sample or a bounce) on different sides: no light is carried
// that way. Light from below the triangle's plane therefore never reaches its top (an open mesh
// with bent normals does not leak), at the price of the energy of the directions between the two
// planes (a few percent at the silhouette of a coarse mesh, none where the normals agree).
inline bool shading_agrees(glm::vec3 w, glm::vec3 ns, glm::vec3 ng) {
  return (glm::dot(w, ns) >= 0.0f) == (glm::dot(w, ng) >= 0.0f);
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
inline glm::vec3 terminator_safe_point(const SmoothCorners& c, float u, float v, glm::vec3 x,
                                       glm::vec3 side) {
  const float w[3] = {1.0f - u - v, u, v};
  glm::vec3 shift(0.0f);
  for (int k = 0; k < 3; ++k) {
    const glm::vec3 nk = glm::dot(c.normal[k], side) < 0.0f ? -c.normal[k] : c.normal[k];
    const float below = glm::dot(x - c.vertex[k], nk);
    if (below < 0.0f) shift -= (w[k] * below) * nk;
  }
  return x + shift;
}

// The same for triangle `tri` of a mesh with vertex normals.
inline glm::vec3 terminator_safe_point(const TriangleMesh& mesh, size_t tri, float u, float v,
                                       glm::vec3 x, glm::vec3 side) {
  return terminator_safe_point(stored_corners(mesh, static_cast<uint32_t>(tri)), u, v, x, side);
}

}  // namespace tritrace
