// The neighbouring floats of x, as std::nextafter(x, +inf) and std::nextafter(x, -inf) give them
// for any x but NaN, inline: the BVH builds widen six box coordinates per triangle by a float step,
// and a library call for each is a noticeable share of a big build (docs/PERFORMANCE.md, "A
// Morton-code build").
#pragma once

#include <bit>
#include <cstdint>
#include <limits>

namespace tritrace {

inline float next_float_up(float x) {
  if (x == std::numeric_limits<float>::infinity()) return x;
  if (x == 0.0f) return std::numeric_limits<float>::denorm_min();  // from +0 and -0 alike
  const uint32_t bits = std::bit_cast<uint32_t>(x);
  // A step away from zero for positive x, toward it for negative (-denorm_min becomes -0).
  return std::bit_cast<float>(x > 0.0f ? bits + 1 : bits - 1);
}

inline float next_float_down(float x) {
  return -next_float_up(-x);
}

}  // namespace tritrace
