// Closest points, distances, signed distances and inside tests on a GeometrySet: the queries of
// issue 28 beyond rays, each answer naming the geometry and its triangle as GeometrySet::locate
// does. Closest points come from the BVH's best-first traversal (bvh/closest_point.h); inside is
// decided by the generalised winding number (bvh/winding_number.h), |w| > 1/2, so that a mesh
// facing inward counts as one facing outward.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <limits>
#include <span>
#include <vector>

#include "tritrace/accel/bvh/winding_number.h"
#include "tritrace/accel/geometry_set.h"
#include "tritrace/geometry/hit.h"
#include "tritrace/geometry/mesh_edges.h"

namespace tritrace {

struct SurfacePoint {
  glm::vec3 point{0.0f};
  float distance = std::numeric_limits<float>::infinity();  // +inf when the set is empty
  uint32_t geometry = kNoHit;                               // kNoHit when nothing was found
  uint32_t prim = kNoHit;  // the triangle's index within its geometry
  // point = (1 - u - v) a + u b + v c for the triangle (a, b, c) as added.
  float u = 0.0f, v = 0.0f;
  // normalize(cross(b - a, c - a)) of that triangle; 0 for a zero-area one.
  glm::vec3 normal{0.0f};
};

// The nearest surface point of the set to each point, out[i] for points[i], over all cores.
// `set` must be built.
void closest_points(const GeometrySet& set, std::span<const glm::vec3> points,
                    std::span<SurfacePoint> out);

// What inside tests need beyond the BVH: the winding-number expansions of its subtrees and, per
// geometry, whether it is closed (its edge counts). Made once per built set.
class InsideTest {
 public:
  // `set` must be built; the test stays valid while the set is neither changed nor rebuilt.
  explicit InsideTest(const GeometrySet& set);

  // Per geometry, in id order.
  const std::vector<EdgeReport>& edges() const { return edges_; }

  // The generalised winding number of all geometries together at p.
  [[nodiscard]] double winding_number(const GeometrySet& set, const glm::vec3& p) const;
  // out[i] = 1 where |winding number| > 1/2 at points[i], else 0; over all cores.
  void occupancy(const GeometrySet& set, std::span<const glm::vec3> points,
                 std::span<uint8_t> out) const;
  // The distance to the nearest surface point, negative where occupancy would say 1.
  void signed_distance(const GeometrySet& set, std::span<const glm::vec3> points,
                       std::span<float> out) const;

 private:
  bvh::WindingNumber winding_;
  std::vector<EdgeReport> edges_;
};

}  // namespace tritrace
