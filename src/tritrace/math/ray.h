// Ray: origin, direction and the parametric interval [tmin, tmax] a hit must fall in.
#pragma once

#include <glm/vec3.hpp>
#include <limits>

namespace tritrace {

// The largest finite float: a kernel that divides by a tiny determinant can produce t = +inf, and a
// finite tmax rejects it without a separate isfinite test.
inline constexpr float kRayTMax = std::numeric_limits<float>::max();

struct Ray {
  glm::vec3 origin{0.0f};
  glm::vec3 dir{0.0f, 0.0f, 1.0f};
  float tmin = 0.0f;
  float tmax = kRayTMax;

  glm::vec3 at(float t) const { return origin + t * dir; }
};

}  // namespace tritrace
