// The ray/triangle kernels. Each solves v0 + u*e1 + v*e2 = o + t*d for (t, u, v) and reports a hit
// when u >= 0, v >= 0, u + v <= 1 (edges inclusive) and tmin <= t <= tmax. A degenerate triangle or
// a ray parallel to the triangle's plane never hits, and no kernel returns NaN or Inf: every test
// is written so that a NaN fails it.
#pragma once

#include <array>
#include <glm/glm.hpp>
#include <optional>
#include <string_view>

#include "tritrace/math/ray.h"

namespace tritrace {

enum class Kernel { kInverse, kCramer, kMollerTrumbore };

inline constexpr std::array<Kernel, 3> kAllKernels = {Kernel::kInverse, Kernel::kCramer,
                                                      Kernel::kMollerTrumbore};

// Measured fastest on the lab scene (docs/PERFORMANCE.md).
inline constexpr Kernel kDefaultKernel = Kernel::kMollerTrumbore;

std::string_view kernel_name(Kernel kernel);  // "inverse", "cramer", "moller-trumbore"
std::optional<Kernel> parse_kernel(std::string_view name);

struct TriangleHit {
  float t;
  float u;
  float v;
};

namespace detail {
inline bool accept(const Ray& ray, float t, float u, float v) {
  return u >= 0.0f && v >= 0.0f && u + v <= 1.0f && t >= ray.tmin && t <= ray.tmax;
}
}  // namespace detail

// The lab's first method: x = A^-1 (o - v0) with A = [-d, e1, e2], inverted by glm::inverse.
inline bool intersect_inverse(const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                              const glm::vec3& e2, TriangleHit& out) {
  const glm::mat3 a(-ray.dir, e1, e2);  // columns
  const float det = glm::determinant(a);
  if (!(det != 0.0f)) return false;
  const glm::vec3 x = glm::inverse(a) * (ray.origin - v0);
  if (!detail::accept(ray, x.x, x.y, x.z)) return false;
  out = {x.x, x.y, x.z};
  return true;
}

// The lab's second method: Cramer's rule, each unknown a ratio of 3x3 determinants. It rejects
// early, after u, before computing the other determinants.
inline bool intersect_cramer(const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                             const glm::vec3& e2, TriangleHit& out) {
  const glm::vec3 nd = -ray.dir;
  const float det = glm::determinant(glm::mat3(nd, e1, e2));
  if (!(det != 0.0f)) return false;
  const float inv_det = 1.0f / det;
  const glm::vec3 b = ray.origin - v0;
  const float u = glm::determinant(glm::mat3(nd, b, e2)) * inv_det;
  if (!(u >= 0.0f && u <= 1.0f)) return false;
  const float v = glm::determinant(glm::mat3(nd, e1, b)) * inv_det;
  if (!(v >= 0.0f && u + v <= 1.0f)) return false;
  const float t = glm::determinant(glm::mat3(b, e1, e2)) * inv_det;
  if (!(t >= ray.tmin && t <= ray.tmax)) return false;
  out = {t, u, v};
  return true;
}

// Möller and Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection", JGT 1997: Cramer's rule
// with the determinants rewritten as triple products that share two cross products.
inline bool intersect_moller_trumbore(const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                                      const glm::vec3& e2, TriangleHit& out) {
  const glm::vec3 p = glm::cross(ray.dir, e2);
  const float det = glm::dot(e1, p);
  if (!(det != 0.0f)) return false;
  const float inv_det = 1.0f / det;
  const glm::vec3 s = ray.origin - v0;
  const float u = glm::dot(s, p) * inv_det;
  if (!(u >= 0.0f && u <= 1.0f)) return false;
  const glm::vec3 q = glm::cross(s, e1);
  const float v = glm::dot(ray.dir, q) * inv_det;
  if (!(v >= 0.0f && u + v <= 1.0f)) return false;
  const float t = glm::dot(e2, q) * inv_det;
  if (!(t >= ray.tmin && t <= ray.tmax)) return false;
  out = {t, u, v};
  return true;
}

template <Kernel K>
inline bool intersect_triangle(const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                               const glm::vec3& e2, TriangleHit& out) {
  if constexpr (K == Kernel::kInverse) {
    return intersect_inverse(ray, v0, e1, e2, out);
  } else if constexpr (K == Kernel::kCramer) {
    return intersect_cramer(ray, v0, e1, e2, out);
  } else {
    return intersect_moller_trumbore(ray, v0, e1, e2, out);
  }
}

// Calls fn.template operator()<K>() with the compile-time kernel matching `kernel`, so that a loop
// over triangles is instantiated once per kernel and the kernel inlines into it. Adding a kernel
// means adding one case here.
template <typename Fn>
decltype(auto) with_kernel(Kernel kernel, Fn&& fn) {
  switch (kernel) {
    case Kernel::kInverse:
      return fn.template operator()<Kernel::kInverse>();
    case Kernel::kCramer:
      return fn.template operator()<Kernel::kCramer>();
    case Kernel::kMollerTrumbore:
      break;
  }
  return fn.template operator()<Kernel::kMollerTrumbore>();
}

// Runtime dispatch for tests and tools; hot loops use the template above.
bool intersect_triangle(Kernel kernel, const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                        const glm::vec3& e2, TriangleHit& out);

}  // namespace tritrace
