// Bounds3: an axis-aligned box. Empty() is inverted (lo = +inf, hi = -inf) so that extending it by
// any point or box gives that point or box.
#pragma once

#include <glm/common.hpp>
#include <glm/vec3.hpp>
#include <limits>

namespace tritrace {

struct Bounds3 {
  glm::vec3 lo{0.0f};
  glm::vec3 hi{0.0f};

  static Bounds3 empty() {
    constexpr float inf = std::numeric_limits<float>::infinity();
    return {glm::vec3(inf), glm::vec3(-inf)};
  }
  void extend(const glm::vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void extend(const Bounds3& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  bool is_empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
  glm::vec3 extent() const { return hi - lo; }
  glm::vec3 centre() const { return (lo + hi) * 0.5f; }
  // Surface area; 0 for an empty box.
  float area() const {
    if (is_empty()) return 0.0f;
    const glm::vec3 e = extent();
    return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
  }
  bool contains(const Bounds3& b) const {
    return lo.x <= b.lo.x && lo.y <= b.lo.y && lo.z <= b.lo.z && hi.x >= b.hi.x && hi.y >= b.hi.y &&
           hi.z >= b.hi.z;
  }
};

}  // namespace tritrace
