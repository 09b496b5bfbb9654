// The exact closest point on a triangle to a point: Ericson's Voronoi-region tests ("Real-Time
// Collision Detection", Morgan Kaufmann 2005, sec. 5.1.5), in double throughout, with triangles of
// (almost) zero area treated as the union of their three edges. Closest-point, distance and
// signed-distance queries (accel/bvh/closest_point.h) call this once per candidate triangle.
#pragma once

#include <glm/vec3.hpp>

namespace tritrace {

// Which feature of the triangle (a, b, c) holds the closest point: one of Ericson's seven Voronoi
// regions, or kDegenerate for a triangle without area, whose closest point is on one of its edges.
enum class TriangleRegion {
  kVertexA,
  kVertexB,
  kVertexC,
  kEdgeAB,
  kEdgeAC,
  kEdgeBC,
  kFace,
  kDegenerate
};

struct TrianglePoint {
  glm::dvec3 point{0.0};
  double distance2 = 0.0;  // |point - p|^2
  // point = (1 - u - v) a + u b + v c, as the ray kernels' (u, v) (v0 + u e1 + v e2).
  double u = 0.0, v = 0.0;
  TriangleRegion region = TriangleRegion::kFace;
};

// A triangle counts as without area when sin^2 of its angle at a is below this: its plane is then
// too ill-defined for the face test (va + vb + vc, the squared cross product, is mostly rounding),
// while its edges still are segments with exact closest points.
inline constexpr double kDegenerateSin2 = 1e-12;

// The point of triangle (a, b, c) closest to p. Exact up to double rounding for every finite input,
// zero-area triangles (collinear corners, repeated corners, a single point) included.
TrianglePoint closest_point_on_triangle(const glm::dvec3& p, const glm::dvec3& a,
                                        const glm::dvec3& b, const glm::dvec3& c);

// The same for float vertices, converted exactly to double.
inline TrianglePoint closest_point_on_triangle(const glm::vec3& p, const glm::vec3& a,
                                               const glm::vec3& b, const glm::vec3& c) {
  return closest_point_on_triangle(glm::dvec3(p), glm::dvec3(a), glm::dvec3(b), glm::dvec3(c));
}

}  // namespace tritrace
