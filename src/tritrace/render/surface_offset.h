// Where rays leave a triangle, and where rays aimed at one stop: the offset start of shadow and
// bounce rays and the end of rays to a light's surface, shared by the path tracer and the
// bidirectional path tracer so that both trace the same geometry.
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
  // offset_ray_origin moves each coordinate by its own ULPs, so the step is not parallel to a
  // tilted triangle: a coordinate moved against the sign of n's would sink the point below the
  // surface, by as much as the step off it lifts it far from the origin (0.95% of rays leaving a
  // sphere light's triangles at (300, -200, 100) hit their own triangle; docs/RELIABILITY.md).
  // Such coordinates stay; the others can only raise the point. On a wall whose normal lies
  // along an axis nothing changes (that component of the step is 0).
  const auto keep = [](float d, float nc) { return d * nc < 0.0f ? 0.0f : d; };
  const glm::vec3 step = inward_length > 0.0f ? inward * (1.0f / inward_length) : glm::vec3(0.0f);
  const glm::vec3 inside =
      inward_length > 0.0f
          ? offset_ray_origin(x, glm::vec3(keep(step.x, n.x), keep(step.y, n.y), keep(step.z, n.z)),
                              extent, offset)
          : x;
  return offset_ray_origin(inside, n, extent, offset);
}

// How far short of a surface a ray aimed at a point on it must stop, per unit of the ray's length.
// The offsets above bound the error of the point itself, which follows its coordinates and its
// triangle's size; but a ray that ends at a surface meets it at t near its full length, and the
// rounding of its direction (normalised from end - start) and of the intersection test's t both
// follow that length: a shadow ray towards a point of a small light triangle (a finely tessellated
// sphere light, or one near the origin, whose coordinates have small ULPs) ended below the surface
// and counted the light's own triangle as a blocker (10% of samples on a sphere of radius 0.25
// in 512 x 256 segments seen from 1.4 away). Measured on that sphere (the kernel's watertight
// test, 170,000 samples): 1 x 2^-24 per unit length still lost 1.7%, 4 x 2^-24 1 in 170,000,
// 8 x 2^-24 none; 16 x 2^-24 = 2^-20 keeps a factor 2 beyond that, and a real blocker is missed
// only when it is within a millionth of the ray's length of the light.
inline constexpr float kRayEndScale = 1.0f / 1048576.0f;

// The end of a ray from `from` that must stop short of a surface: `end` is the point already moved
// off its surface by offset_ray_origin or leave_surface towards the unit normal `side` (the side
// `from` is on); it moves on along `side` by kRayEndScale times the ray's length.
[[gnu::always_inline]] inline glm::vec3 stop_short_of_surface(glm::vec3 end, glm::vec3 side,
                                                              glm::vec3 from) {
  const glm::vec3 segment = end - from;
  return end + side * (kRayEndScale * std::sqrt(glm::dot(segment, segment)));
}

}  // namespace tritrace
