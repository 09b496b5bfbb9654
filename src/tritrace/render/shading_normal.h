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

// A tangent T along which the texture coordinates of set `set` grow in u, and the sign w that makes
// w cross(n, T) point along growing v, from triangle `prim`'s corner coordinates (the per-triangle
// tangent of Mikkelsen, "Simulation of Wrinkled Surfaces Revisited", 2008, section 4.2: the
// derivatives dp/du and dp/dv of the triangle's linear map from texture to surface). Zero where
// the coordinates have no area.
inline glm::vec4 triangle_tangent(const Scene& scene, uint32_t prim, int set, glm::vec3 n) {
  const SurfaceTriangle t = scene.triangle(prim);
  const glm::vec2 t0 = scene.uv(prim, 0.0f, 0.0f, set);
  const glm::vec2 d1 = scene.uv(prim, 1.0f, 0.0f, set) - t0;
  const glm::vec2 d2 = scene.uv(prim, 0.0f, 1.0f, set) - t0;
  const float r = d1.x * d2.y - d2.x * d1.y;
  if (!(std::abs(r) > 0.0f) || !std::isfinite(r)) return glm::vec4(0.0f);
  const glm::vec3 dpdu = (t.e1 * d2.y - t.e2 * d1.y) / r;
  const glm::vec3 dpdv = (t.e2 * d1.x - t.e1 * d2.x) / r;
  return {dpdu, glm::dot(glm::cross(n, dpdu), dpdv) < 0.0f ? -1.0f : 1.0f};
}

// The shading normal a tangent-space normal map gives (glTF 2.0, section 3.9.3): the texel t at
// the hit read as m = 2 t - 1, its x and y times normal_scale, in the frame of the tangent T (the
// mesh's, else triangle_tangent's), made perpendicular to the shading normal n (Gram-Schmidt), the
// bitangent B = w cross(n, T) and n: normalize(m.x T + m.y B + m.z n). `n` is the smooth or flat
// shading normal on the side of `ng`; it is returned unchanged where there is no tangent frame (no
// texture coordinates) or where the mapped normal would point below the triangle's plane.
inline glm::vec3 normal_mapped(const Scene& scene, const Material& mat, uint32_t prim, float u,
                               float v, glm::vec3 n, glm::vec3 ng) {
  glm::vec4 t = scene.tangent(prim, u, v);
  if (t.x == 0.0f && t.y == 0.0f && t.z == 0.0f) {
    t = triangle_tangent(scene, prim, mat.normal_texture.texcoord, n);
  }
  glm::vec3 tangent = glm::vec3(t) - glm::dot(glm::vec3(t), n) * n;
  const float len2 = glm::dot(tangent, tangent);
  if (!(len2 > 0.0f) || !std::isfinite(len2)) return n;
  tangent *= 1.0f / std::sqrt(len2);
  const glm::vec3 bitangent = (t.w < 0.0f ? -1.0f : 1.0f) * glm::cross(n, tangent);
  const glm::vec3 texel = textured(scene, mat.normal_texture, glm::vec3(1.0f), prim, u, v);
  const glm::vec3 m = 2.0f * texel - 1.0f;
  const glm::vec3 mapped = mat.normal_scale * (m.x * tangent + m.y * bitangent) + m.z * n;
  const float m2 = glm::dot(mapped, mapped);
  if (!(m2 > 0.0f) || !std::isfinite(m2)) return n;
  const glm::vec3 out = mapped * (1.0f / std::sqrt(m2));
  return glm::dot(out, ng) > 0.0f ? out : n;
}

// The shading normal of material `mat` at barycentrics (u, v) of triangle `prim` with corners `c`
// (Scene::any_corners), on the side of `ng`: the interpolated vertex normal, bent by the material's
// normal map where it has one.
inline glm::vec3 surface_normal(const Scene& scene, const Material& mat, uint32_t prim,
                                const SmoothCorners& c, float u, float v, glm::vec3 ng) {
  const glm::vec3 ns = oriented_shading_normal(c, u, v, ng);
  return mat.normal_texture.present() ? normal_mapped(scene, mat, prim, u, v, ns, ng) : ns;
}

// Whether triangle `prim` of material `mat` shades with a normal of its own (vertex normals or a
// normal map) rather than its geometric normal.
inline bool shades_smooth(const Scene& scene, const Material& mat, uint32_t prim) {
  return mat.normal_texture.present() || scene.smooth(prim);
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
