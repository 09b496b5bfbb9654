// Where a secondary ray starts: the hit point pushed off its surface, so that the ray cannot hit
// the surface it leaves and does not start behind a neighbouring one, at any scale or distance
// from the origin.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <glm/common.hpp>
#include <glm/vec3.hpp>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace tritrace {

// After Wächter and Binder, "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing
// Gems (2019), chapter 6. Two errors put a computed hit point off its surface and make a ray that
// leaves it hit it again:
//  - rounding of the point itself, relative to the magnitude of its coordinates: the paper moves
//    each coordinate by `int_scale * n` units in the last place (ULPs), on the float's bit
//    pattern, so the offset follows the coordinate's magnitude wherever the scene sits;
//  - rounding inside the intersection test, relative to the size of the triangles it works on:
//    the paper covers it near zero (|p| < 1/32) with a fixed `1/65536 * n`, which assumes a scene
//    of size about 1. Here that fixed offset is `float_scale * extent * n`, with `extent` the size
//    of the surface around p (the hit triangle's longest edge component), and is a floor
//    everywhere: each coordinate moves by the larger of the two offsets.
// So the offset scales with the scene (the lab box at 1e-3 or 1e4 gives the same image) and with
// its distance from the origin (at 1e4 it is a few ULPs of 1e4). The paper's int_scale of 256
// allows for hit points computed as o + t d on GPUs; ours come from barycentrics, within about
// 2 ULPs, and 256 ULPs of 1e4 (0.25) would visibly move shadows. The constants are measured in
// docs/RELIABILITY.md.
struct RayOffsetParams {
  float int_scale = 4.0f;               // ULPs per unit of normal component
  float float_scale = 1.0f / 65536.0f;  // times extent, per unit of normal component
};

// p moved to the side of its surface that the unit normal `n` points to, one coordinate at a time
// (the reference; offset_ray_origin is this, bit for bit, in SIMD where the build has AVX2).
inline glm::vec3 offset_ray_origin_scalar(glm::vec3 p, glm::vec3 n, float extent,
                                          const RayOffsetParams& k = {}) {
  auto shift = [&](float pc, float nc) {
    // A positive float's bits grow with its value, a negative float's with its magnitude: moving
    // towards +n means adding ULPs to a positive coordinate and removing them from a negative one.
    // Unsigned arithmetic: the bit pattern wraps rather than overflows.
    const auto ulps = static_cast<int32_t>(k.int_scale * nc);
    const uint32_t bits = std::bit_cast<uint32_t>(pc);
    const float by_ulps =
        std::bit_cast<float>(bits + static_cast<uint32_t>(pc < 0.0f ? -ulps : ulps));
    const float by_extent = pc + k.float_scale * extent * nc;
    // Near zero the ULP step can cross zero (even into a NaN pattern) or shrink to nothing; the
    // extent term then rules. by_extent comes first so that a NaN by_ulps loses.
    return nc > 0.0f ? std::max(by_extent, by_ulps) : std::min(by_extent, by_ulps);
  };
  return {shift(p.x, n.x), shift(p.y, n.y), shift(p.z, n.z)};
}

// p moved to the side of its surface that the unit normal `n` points to.
inline glm::vec3 offset_ray_origin(glm::vec3 p, glm::vec3 n, float extent,
                                   const RayOffsetParams& k = {}) {
#if defined(__AVX2__)
  // offset_ray_origin_scalar, three lanes at once (the path tracer offsets three points per
  // vertex, a visible share of its work): the same IEEE operations, and max/min with
  // std::max/std::min's operand order and NaN rule (_mm_max_ps(b, a) is b > a ? b : a, which is
  // std::max(a, b)).
  const __m128 pv = _mm_setr_ps(p.x, p.y, p.z, 0.0f), nv = _mm_setr_ps(n.x, n.y, n.z, 0.0f);
  const __m128i ulps = _mm_cvttps_epi32(_mm_mul_ps(_mm_set1_ps(k.int_scale), nv));
  const __m128i signed_ulps = _mm_blendv_epi8(ulps, _mm_sub_epi32(_mm_setzero_si128(), ulps),
                                              _mm_castps_si128(_mm_cmplt_ps(pv, _mm_setzero_ps())));
  const __m128 by_ulps = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(pv), signed_ulps));
  const __m128 by_extent = _mm_add_ps(pv, _mm_mul_ps(_mm_set1_ps(k.float_scale * extent), nv));
  const __m128 r = _mm_blendv_ps(_mm_min_ps(by_ulps, by_extent), _mm_max_ps(by_ulps, by_extent),
                                 _mm_cmpgt_ps(nv, _mm_setzero_ps()));
  alignas(16) float out[4];
  _mm_store_ps(out, r);
  return {out[0], out[1], out[2]};
#else
  return offset_ray_origin_scalar(p, n, extent, k);
#endif
}

// The extent offset_ray_origin wants for a triangle with edges e1, e2: its largest edge component.
inline float triangle_extent(glm::vec3 e1, glm::vec3 e2) {
  const glm::vec3 a = glm::max(glm::abs(e1), glm::abs(e2));
  return std::max({a.x, a.y, a.z});
}

}  // namespace tritrace
