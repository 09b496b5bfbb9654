// Hit: the closest intersection found along a ray, or kNoHit.
#pragma once

#include <cstdint>
#include <limits>

#include "tritrace/math/ray.h"

namespace tritrace {

inline constexpr uint32_t kNoHit = std::numeric_limits<uint32_t>::max();

struct Hit {
  float t = kRayTMax;
  float u = 0.0f;  // barycentric weight of v1 (hit point = v0 + u*e1 + v*e2)
  float v = 0.0f;  // barycentric weight of v2
  uint32_t prim = kNoHit;

  bool found() const { return prim != kNoHit; }
};

}  // namespace tritrace
