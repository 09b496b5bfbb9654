// Ray crossings counted once: the watertight kernel (intersect.h) with its one tie broken, for
// queries that count or list every triangle a ray passes through. The watertight kernel counts
// edges as inside, so a ray through an edge shared by two triangles hits both, and one through a
// vertex hits every triangle around it: right for the first hit, wrong for a count.
//
// The rule: an edge function that is exactly 0 (the ray passes through the edge's line in the
// sheared plane, decided exactly in double as the kernel does) takes the sign it would have if the
// ray's origin were moved by (e, e^2) in the sheared plane, for an infinitesimal e > 0 (symbolic
// perturbation, Edelsbrunner and Mücke, "Simulation of Simplicity", ACM TOG 9(1), 1990; the same
// idea as a rasteriser's top-left fill rule). For the edge function E of the directed edge p -> q,
// E(origin + (e, e^2)) = E - e (q.y - p.y) + e^2 (q.x - p.x), so a zero E takes the sign of
// p.y - q.y, or where that is 0 the sign of q.x - p.x; both are exact float differences of the
// sheared vertices, which neighbouring triangles share bit for bit.
//
// So every triangle is tested against one and the same point, the moved one, which lies on no edge
// of any triangle with a nonzero projected area: each crossing is counted exactly once, in exactly
// one of the triangles sharing an edge or a vertex, and a ray that grazes an edge or touches a
// vertex without entering counts as the parallel ray moved infinitesimally would (0 or 2 for a
// closed mesh seen from outside, never 1). A triangle seen edge-on (det = 0) or of zero area is
// never crossed: the moved point's three edge functions sum to det and cannot share one sign. The
// reported t, u, v are the kernel's, at the ray itself.
#pragma once

#include <glm/vec3.hpp>

#include "tritrace/geometry/intersect.h"

namespace tritrace {
namespace detail {

// The sign (as -1, 0, 1) of the edge function of p -> q at the moved origin, given its exact
// value e at the origin.
inline int perturbed_sign(double e, const Sheared& p, const Sheared& q) {
  if (e != 0.0) return e > 0.0 ? 1 : -1;
  const float dy = q.y - p.y;  // exact in sign, 0 only when equal
  if (dy != 0.0f) return dy < 0.0f ? 1 : -1;
  const float dx = q.x - p.x;
  return dx > 0.0f ? 1 : dx < 0.0f ? -1 : 0;
}

// The tie-broken test of a ray through an edge or a vertex (some float edge function is 0): the
// three edge functions exactly, their zeros perturbed, then the kernel's t, u, v.
template <int Kz>
inline bool crossing_on_edge(const WatertightRay& ray, const Sheared& a, const Sheared& b,
                             const Sheared& c, TriangleHit& out) {
  const double ud = edge_exact(c, b);
  const double vd = edge_exact(a, c);
  const double wd = edge_exact(b, a);
  const int su = perturbed_sign(ud, c, b);
  const int sv = perturbed_sign(vd, a, c);
  const int sw = perturbed_sign(wd, b, a);
  if (su == 0 || su != sv || su != sw) return false;
  const float u = static_cast<float>(ud), v = static_cast<float>(vd), w = static_cast<float>(wd);
  return watertight_hit(ray, a, b, c, u, v, w, out);
}

template <int Kz>
inline bool crossing_watertight_axis(const WatertightRay& ray, const glm::vec3& v0,
                                     const glm::vec3& v1, const glm::vec3& v2, TriangleHit& out) {
  const Sheared a = shear<Kz>(ray, v0);
  const Sheared b = shear<Kz>(ray, v1);
  const Sheared c = shear<Kz>(ray, v2);
  const float u = edge(c, b);
  const float v = edge(a, c);
  const float w = edge(b, a);
  if (u == 0.0f || v == 0.0f || w == 0.0f) [[unlikely]] {
    return crossing_on_edge<Kz>(ray, a, b, c, out);
  }
  // No zero: the kernel's own test, operation for operation.
  const bool all_pos = u > 0.0f && v > 0.0f && w > 0.0f;
  const bool all_neg = u < 0.0f && v < 0.0f && w < 0.0f;
  if (!(all_pos || all_neg)) return false;
  return watertight_hit(ray, a, b, c, u, v, w, out);
}

}  // namespace detail

// Whether the ray crosses the triangle (v0, v1, v2) within [tmin, tmax] under the rule above; on
// true, out holds the kernel's t, u, v. Summed over the triangles of a closed mesh, the crossings
// along a whole line are even.
inline bool cross_watertight(const WatertightRay& ray, const glm::vec3& v0, const glm::vec3& v1,
                             const glm::vec3& v2, TriangleHit& out) {
  switch (ray.kz) {
    case 0:
      return detail::crossing_watertight_axis<0>(ray, v0, v1, v2, out);
    case 1:
      return detail::crossing_watertight_axis<1>(ray, v0, v1, v2, out);
    default:
      return detail::crossing_watertight_axis<2>(ray, v0, v1, v2, out);
  }
}

}  // namespace tritrace
