// Ericson's closest point on a triangle (Real-Time Collision Detection, sec. 5.1.5): the point's
// dot products with the edges place it in one of the seven Voronoi regions of the triangle
// (three vertices, three edges, the face), each with a closed-form closest point.
#include "tritrace/geometry/point_triangle_distance.h"

#include <algorithm>
#include <glm/geometric.hpp>

namespace tritrace {
namespace {

TrianglePoint make(const glm::dvec3& p, const glm::dvec3& q, double u, double v,
                   TriangleRegion region) {
  const glm::dvec3 d = q - p;
  return {q, glm::dot(d, d), u, v, region};
}

// The closest point to p on segment [s, s + d], as the parameter t in [0, 1].
double segment_parameter(const glm::dvec3& p, const glm::dvec3& s, const glm::dvec3& d) {
  const double dd = glm::dot(d, d);
  if (!(dd > 0.0)) return 0.0;
  return std::clamp(glm::dot(p - s, d) / dd, 0.0, 1.0);
}

// A triangle without area is the union of its edges: the nearest of the three segments' closest
// points, with barycentrics on the segment's two corners.
TrianglePoint closest_on_edges(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                               const glm::dvec3& c) {
  const double t_ab = segment_parameter(p, a, b - a);
  const double t_ac = segment_parameter(p, a, c - a);
  const double t_bc = segment_parameter(p, b, c - b);
  TrianglePoint best = make(p, a + t_ab * (b - a), t_ab, 0.0, TriangleRegion::kDegenerate);
  const TrianglePoint on_ac = make(p, a + t_ac * (c - a), 0.0, t_ac, TriangleRegion::kDegenerate);
  if (on_ac.distance2 < best.distance2) best = on_ac;
  const TrianglePoint on_bc =
      make(p, b + t_bc * (c - b), 1.0 - t_bc, t_bc, TriangleRegion::kDegenerate);
  if (on_bc.distance2 < best.distance2) best = on_bc;
  return best;
}

}  // namespace

TrianglePoint closest_point_on_triangle(const glm::dvec3& p, const glm::dvec3& a,
                                        const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a;
  const glm::dvec3 n = glm::cross(ab, ac);
  const double n2 = glm::dot(n, n);
  if (!(n2 > kDegenerateSin2 * glm::dot(ab, ab) * glm::dot(ac, ac))) {
    return closest_on_edges(p, a, b, c);
  }
  // Vertex region A: p is behind both edges leaving a.
  const glm::dvec3 ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return make(p, a, 0.0, 0.0, TriangleRegion::kVertexA);
  // Vertex region B.
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return make(p, b, 1.0, 0.0, TriangleRegion::kVertexB);
  // Edge region AB: vc is the (scaled) barycentric of c, negative outside edge AB.
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double t = d1 / (d1 - d3);
    return make(p, a + t * ab, t, 0.0, TriangleRegion::kEdgeAB);
  }
  // Vertex region C.
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return make(p, c, 0.0, 1.0, TriangleRegion::kVertexC);
  // Edge region AC.
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double t = d2 / (d2 - d6);
    return make(p, a + t * ac, 0.0, t, TriangleRegion::kEdgeAC);
  }
  // Edge region BC.
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return make(p, b + t * (c - b), 1.0 - t, t, TriangleRegion::kEdgeBC);
  }
  // Face region: the projection onto the plane, by its barycentrics (va + vb + vc = |n|^2 > 0).
  const double inv = 1.0 / (va + vb + vc);
  const double u = vb * inv, v = vc * inv;
  return make(p, a + u * ab + v * ac, u, v, TriangleRegion::kFace);
}

}  // namespace tritrace
