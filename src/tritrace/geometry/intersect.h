// The ray/triangle kernels. Each solves v0 + u*e1 + v*e2 = o + t*d for (t, u, v) and reports a hit
// when u >= 0, v >= 0, u + v <= 1 (edges inclusive) and tmin <= t <= tmax. A degenerate triangle or
// a ray parallel to the triangle's plane never hits, and no kernel returns NaN or Inf: every test
// is written so that a NaN fails it.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <optional>
#include <string_view>

#include "tritrace/math/ray.h"

#if defined(__AVX__)
#include <immintrin.h>
#endif

namespace tritrace {

enum class Kernel { kInverse, kCramer, kMollerTrumbore, kWatertight };

inline constexpr std::array<Kernel, 4> kAllKernels = {Kernel::kInverse, Kernel::kCramer,
                                                      Kernel::kMollerTrumbore, Kernel::kWatertight};

// The default everywhere: no ray slips between two triangles that share an edge or a vertex. The
// BVH runs it in SIMD leaves and packets at close to the speed of Möller–Trumbore, the fastest
// kernel, and brute force little slower (docs/PERFORMANCE.md, "Robust intersection" and
// "Watertight by default").
inline constexpr Kernel kDefaultKernel = Kernel::kWatertight;

// "inverse", "cramer", "moller-trumbore", "watertight"
std::string_view kernel_name(Kernel kernel);
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

// Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013.
//
// The ray is turned into the +z axis by a permutation (kz = the largest |dir| component) and a
// shear, so that each triangle reduces to a 2D point-in-triangle test of the origin against the
// sheared vertices. The three edge functions U, V, W are computed from the vertices alone, and
// swapping an edge's two vertices negates its edge function exactly, so two triangles sharing an
// edge always put a ray on opposite sides of it, or on it (and edges are inclusive): no ray slips
// through. That needs the vertices themselves (v0 + e1 is not v1 in float) and no fused
// multiply-add in the edge functions or the shear (the project builds with -ffp-contract=off;
// fusing one product of a difference but not the other breaks the exact negation).
struct WatertightRay {
  int kz = 2;  // the dominant axis of dir; kx = kz + 1 and ky = kz + 2 (mod 3)
  // The origin's coordinates in permuted order (kx, ky, kz).
  float ox = 0.0f, oy = 0.0f, oz = 0.0f;
  float sx = 0.0f, sy = 0.0f, sz = 1.0f;  // shear: dir[kx]/dir[kz], dir[ky]/dir[kz], 1/dir[kz]
  float tmin = 0.0f;
  float tmax = kRayTMax;
};

// The watertight kernel's dominant axis of `dir` (WatertightRay::kz): 1 where |dy| > |dx|, else
// 0; 2 where |dz| exceeds both (ties go to the lower axis; 0 for NaN).
inline int watertight_axis(const glm::vec3& dir) {
  const float ax = std::abs(dir.x), ay = std::abs(dir.y), az = std::abs(dir.z);
  const int k01 = static_cast<int>(ay > ax);
  const int z_wins = static_cast<int>(az > std::max(ax, ay));
  return k01 + z_wins * (2 - k01);
}

// Per-ray work, done once and reused for every triangle. The paper also swaps kx and ky when
// dir[kz] < 0 to keep each triangle's winding; both sides count as hits here and t, u, v do not
// depend on it, so the swap is left out.
// Branch-free with SSE/AVX: the axis picks a lane permutation rather than an element, since rays
// come in any direction and the compiler turned the scalar version's selects into branches that
// mispredicted on most incoherent rays (docs/PERFORMANCE.md, issue 27). Both versions do the same
// IEEE operations (one division, two products) on the same operands, so their bits are the same.
inline WatertightRay prepare_watertight(const Ray& ray) {
  WatertightRay w;
  const std::array<float, 3> d = std::bit_cast<std::array<float, 3>>(ray.dir);
  const std::array<float, 3> o = std::bit_cast<std::array<float, 3>>(ray.origin);
  w.kz = watertight_axis(ray.dir);
  bool finite;
#if defined(__AVX__)
  // Lane orders (kx, ky, kz, -) for kz = 0, 1, 2.
  alignas(16) static constexpr int32_t kOrder[3][4] = {{1, 2, 0, 3}, {2, 0, 1, 3}, {0, 1, 2, 3}};
  const __m128i order = _mm_load_si128(reinterpret_cast<const __m128i*>(kOrder[w.kz]));
  const __m128 pd = _mm_permutevar_ps(_mm_setr_ps(d[0], d[1], d[2], 1.0f), order);
  const __m128 po = _mm_permutevar_ps(_mm_setr_ps(o[0], o[1], o[2], 0.0f), order);
  const float dz = _mm_cvtss_f32(_mm_movehl_ps(pd, pd));
  w.sz = 1.0f / dz;
  // (dx, dy) * sz in lanes 0 and 1; lane 2 gets sz itself and lane 3 stays 0.
  const __m128 shear =
      _mm_mul_ps(_mm_blend_ps(pd, _mm_setr_ps(0.0f, 0.0f, 1.0f, 0.0f), 0b1100), _mm_set1_ps(w.sz));
  w.sx = _mm_cvtss_f32(shear);
  w.sy = _mm_cvtss_f32(_mm_shuffle_ps(shear, shear, 1));
  alignas(16) float origin[4];
  _mm_store_ps(origin, po);
  w.ox = origin[0];
  w.oy = origin[1];
  w.oz = origin[2];
  // x - x is 0 for every finite x and NaN for infinities and NaN: the origin, sx, sy and sz are
  // finite when every lane's difference equals zero (the fourth lanes hold zeros).
  const __m128 ok = _mm_and_ps(_mm_cmpeq_ps(_mm_sub_ps(po, po), _mm_setzero_ps()),
                               _mm_cmpeq_ps(_mm_sub_ps(shear, shear), _mm_setzero_ps()));
  finite = _mm_movemask_ps(ok) == 0xF && w.sz != 0.0f;
#else
  const int kx = w.kz == 2 ? 0 : w.kz + 1;
  const int ky = kx == 2 ? 0 : kx + 1;
  w.ox = o[kx];
  w.oy = o[ky];
  w.oz = o[w.kz];
  w.sz = 1.0f / d[w.kz];
  w.sx = d[kx] * w.sz;
  w.sy = d[ky] * w.sz;
  finite = std::isfinite(o[0]) && std::isfinite(o[1]) && std::isfinite(o[2]) &&
           std::isfinite(w.sx) && std::isfinite(w.sy) && std::isfinite(w.sz) && w.sz != 0.0f;
#endif
  // A zero, infinite or NaN direction (or origin) hits nothing: an empty t interval says so
  // without a branch in the per-triangle test.
  w.tmin = finite ? ray.tmin : kRayTMax;
  w.tmax = finite ? ray.tmax : -kRayTMax;
  return w;
}

// prepare_watertight for a ray whose dominant axis (watertight_axis) is Kz, given sz = 1.0f /
// ray.dir[Kz] already divided by the caller (the BVH's box test divides the same, so the
// traversal divides once): the same operations on the same operands, so the same bits, without
// the permutation of a run-time axis.
template <int Kz>
inline WatertightRay prepare_watertight_axis(const Ray& ray, float sz) {
  constexpr int kKx = (Kz + 1) % 3, kKy = (Kz + 2) % 3;
  WatertightRay w;
  w.kz = Kz;
  w.ox = ray.origin[kKx];
  w.oy = ray.origin[kKy];
  w.oz = ray.origin[Kz];
  w.sz = sz;
  w.sx = ray.dir[kKx] * sz;
  w.sy = ray.dir[kKy] * sz;
  // & rather than &&: no branches (the rays come in any direction); on ints, which & is for.
  const bool finite =
      (int{std::isfinite(w.ox)} & int{std::isfinite(w.oy)} & int{std::isfinite(w.oz)} &
       int{std::isfinite(w.sx)} & int{std::isfinite(w.sy)} & int{std::isfinite(w.sz)} &
       int{w.sz != 0.0f}) != 0;
  w.tmin = finite ? ray.tmin : kRayTMax;
  w.tmax = finite ? ray.tmax : -kRayTMax;
  return w;
}

namespace detail {
// The sheared position of a vertex relative to the ray origin.
struct Sheared {
  float x, y, z;
};
// One function for all three vertices, so a vertex shared by two triangles gets the same bits in
// both. The axis is a template parameter so that the permutation costs nothing per triangle.
template <int Kz>
inline Sheared shear(const WatertightRay& r, const glm::vec3& p) {
  constexpr int kKx = (Kz + 1) % 3, kKy = (Kz + 2) % 3;
  const float qx = p[kKx] - r.ox, qy = p[kKy] - r.oy, qz = p[Kz] - r.oz;
  return {qx - r.sx * qz, qy - r.sy * qz, qz};
}
// The 2D edge function a.x*b.y - a.y*b.x; edge(b, a) == -edge(a, b) exactly.
inline float edge(const Sheared& a, const Sheared& b) {
  return a.x * b.y - a.y * b.x;
}
// Float products of floats are exact in double (24 + 24 bits < 53), so the difference is rounded
// once and its sign is the true sign: the paper's fallback when the float result is exactly 0.
inline double edge_exact(const Sheared& a, const Sheared& b) {
  return static_cast<double>(a.x) * static_cast<double>(b.y) -
         static_cast<double>(a.y) * static_cast<double>(b.x);
}

// The kernel's last step, once the edge functions U, V, W have passed the inside test: the
// determinant, t = sz * (U az + V bz + W cz) / det (the distance along the sheared z axis,
// rescaled) within [tmin, tmax], and the barycentrics. Shared with the crossing test
// (crossing.h) so that both give the same t, u, v bit for bit.
[[gnu::always_inline]] inline bool watertight_hit(const WatertightRay& ray, const Sheared& a,
                                                  const Sheared& b, const Sheared& c, float u,
                                                  float v, float w, TriangleHit& out) {
  const float det = u + v + w;
  if (!(det != 0.0f)) return false;  // the ray lies in the triangle's plane, or it is degenerate
  const float inv_det = 1.0f / det;
  const float t = (u * a.z + v * b.z + w * c.z) * (ray.sz * inv_det);
  if (!(t >= ray.tmin && t <= ray.tmax)) return false;
  out = {t, v * inv_det, w * inv_det};
  return true;
}

template <int Kz>
inline bool intersect_watertight_axis(const WatertightRay& ray, const glm::vec3& v0,
                                      const glm::vec3& v1, const glm::vec3& v2, TriangleHit& out) {
  const Sheared a = shear<Kz>(ray, v0);
  const Sheared b = shear<Kz>(ray, v1);
  const Sheared c = shear<Kz>(ray, v2);
  // Early out: all three vertices strictly on one side of the ray in x or in y. This is exact on
  // the sheared vertices, and the edge test below would reject the same triangle, so it changes
  // no answer (watertightness included); it only spares most far-away triangles the edge functions.
  if ((a.x > 0.0f && b.x > 0.0f && c.x > 0.0f) || (a.x < 0.0f && b.x < 0.0f && c.x < 0.0f) ||
      (a.y > 0.0f && b.y > 0.0f && c.y > 0.0f) || (a.y < 0.0f && b.y < 0.0f && c.y < 0.0f)) {
    return false;
  }
  // U weighs v0, V weighs v1, W weighs v2.
  float u = edge(c, b);
  float v = edge(a, c);
  float w = edge(b, a);
  // A float edge function has the true sign or is 0 (rounding is monotonic), so only a 0 needs
  // the exact value; the neighbour sharing that edge gets the same 0 and takes this path too.
  if (u == 0.0f || v == 0.0f || w == 0.0f) [[unlikely]] {
    const double ud = edge_exact(c, b);
    const double vd = edge_exact(a, c);
    const double wd = edge_exact(b, a);
    if ((ud < 0.0 || vd < 0.0 || wd < 0.0) && (ud > 0.0 || vd > 0.0 || wd > 0.0)) return false;
    u = static_cast<float>(ud);
    v = static_cast<float>(vd);
    w = static_cast<float>(wd);
  }
  // Inside when all three have the same sign (zero counts as either: edges are inclusive). Written
  // so that a NaN fails it.
  const bool all_nonneg = u >= 0.0f && v >= 0.0f && w >= 0.0f;
  const bool all_nonpos = u <= 0.0f && v <= 0.0f && w <= 0.0f;
  if (!(all_nonneg || all_nonpos)) return false;
  return watertight_hit(ray, a, b, c, u, v, w, out);
}
}  // namespace detail

inline bool intersect_watertight(const WatertightRay& ray, const glm::vec3& v0, const glm::vec3& v1,
                                 const glm::vec3& v2, TriangleHit& out) {
  // In a loop over one ray's triangles this switch always goes the same way.
  switch (ray.kz) {
    case 0:
      return detail::intersect_watertight_axis<0>(ray, v0, v1, v2, out);
    case 1:
      return detail::intersect_watertight_axis<1>(ray, v0, v1, v2, out);
    default:
      return detail::intersect_watertight_axis<2>(ray, v0, v1, v2, out);
  }
}

// The same contract as the other kernels, from v0, e1, e2. v0 + e1 rounds, so triangles meeting
// this way are only as watertight as that rounding allows: loops over a mesh use the vertex form
// through PreparedRay below.
inline bool intersect_watertight(const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                                 const glm::vec3& e2, TriangleHit& out) {
  return intersect_watertight(prepare_watertight(ray), v0, v0 + e1, v0 + e2, out);
}

template <Kernel K>
inline bool intersect_triangle(const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                               const glm::vec3& e2, TriangleHit& out) {
  if constexpr (K == Kernel::kInverse) {
    return intersect_inverse(ray, v0, e1, e2, out);
  } else if constexpr (K == Kernel::kCramer) {
    return intersect_cramer(ray, v0, e1, e2, out);
  } else if constexpr (K == Kernel::kMollerTrumbore) {
    return intersect_moller_trumbore(ray, v0, e1, e2, out);
  } else {
    return intersect_watertight(ray, v0, e1, e2, out);
  }
}

// The triangle arrays a loop over a mesh reads (TriangleMesh::arrays()): the vertices exactly as
// given. The watertight kernel reads them; the others read v0 and the edges v1 - v0, v2 - v0.
struct TriangleArrays {
  const glm::vec3* v0 = nullptr;
  const glm::vec3* v1 = nullptr;
  const glm::vec3* v2 = nullptr;
};

// A ray with kernel K's per-ray work done, for loops that test one ray against many triangles:
//   const PreparedRay<K> pr(ray);
//   for (i ...) if (pr.intersect(tris, i, hit)) ...
template <Kernel K>
class PreparedRay {
 public:
  explicit PreparedRay(const Ray& ray) : ray_(ray) {}
  bool intersect(const TriangleArrays& tris, size_t i, TriangleHit& out) const {
    const glm::vec3 v0 = tris.v0[i];
    return intersect_triangle<K>(ray_, v0, tris.v1[i] - v0, tris.v2[i] - v0, out);
  }

 private:
  Ray ray_;
};

template <>
class PreparedRay<Kernel::kWatertight> {
 public:
  explicit PreparedRay(const Ray& ray) : ray_(prepare_watertight(ray)) {}
  explicit PreparedRay(const WatertightRay& prepared) : ray_(prepared) {}
  bool intersect(const TriangleArrays& tris, size_t i, TriangleHit& out) const {
    return intersect_watertight(ray_, tris.v0[i], tris.v1[i], tris.v2[i], out);
  }
  const WatertightRay& watertight() const { return ray_; }

 private:
  WatertightRay ray_;
};

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
      return fn.template operator()<Kernel::kMollerTrumbore>();
    case Kernel::kWatertight:
      break;
  }
  return fn.template operator()<Kernel::kWatertight>();
}

// Runtime dispatch for tests and tools; hot loops use the templates above.
bool intersect_triangle(Kernel kernel, const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                        const glm::vec3& e2, TriangleHit& out);

}  // namespace tritrace
