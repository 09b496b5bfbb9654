// Where rays leave a triangle: the offset start of shadow and bounce rays, shared by the path
// tracer and the bidirectional path tracer so that both trace the same geometry.
#pragma once

#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "tritrace/math/offset_ray.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// A point on triangle `tri` moved off it towards the side `n` (its normal, facing the way the ray
// leaves), first towards the centroid (a point on an edge lies on the neighbour's plane too) then
// off the surface, as the lab's shadow rays start (lab_integrator.cpp; Wächter and Binder 2019).
[[gnu::always_inline]] inline glm::vec3 leave_surface(const SurfaceTriangle& tri, glm::vec3 x,
                                                      glm::vec3 n, const RayOffsetParams& offset) {
  const glm::vec3 e1 = tri.e1, e2 = tri.e2;
  const float extent = triangle_extent(e1, e2);
  const glm::vec3 inward = tri.v0 + (e1 + e2) / 3.0f - x;
  const float inward_length = std::sqrt(glm::dot(inward, inward));
  const glm::vec3 inside =
      inward_length > 0.0f ? offset_ray_origin(x, inward * (1.0f / inward_length), extent, offset)
                           : x;
  return offset_ray_origin(inside, n, extent, offset);
}

}  // namespace tritrace
