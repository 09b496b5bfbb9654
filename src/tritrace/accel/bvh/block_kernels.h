// One ray against a whole triangle block (the BVH's leaf): shared by the single-ray traversal and
// by the packet traversal, which hands it the few rays of a packet that reach a leaf.
#pragma once

#include <bit>
#include <cstdint>

#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/hit.h"
#include "tritrace/math/ray.h"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace tritrace::bvh {

// (t, prim) ordered lexicographically: the closer hit wins, and on a tie the earlier triangle, as
// in the brute-force loop.
inline void offer(Hit& best, float t, float u, float v, uint32_t prim) {
  if (t < best.t || (t == best.t && prim < best.prim)) best = {t, u, v, prim};
}

#if defined(__AVX2__)
// Möller–Trumbore on eight triangles at once. Every lane performs the scalar kernel's operations in
// the same order (glm's cross and dot, no fused multiply-adds), so its results are bit-identical to
// intersect_moller_trumbore's.
inline bool block_moller_trumbore(const TriangleBlock& b, const Ray& ray, Hit* best) {
  const __m256 dx = _mm256_set1_ps(ray.dir.x), dy = _mm256_set1_ps(ray.dir.y),
               dz = _mm256_set1_ps(ray.dir.z);
  const __m256 e1x = _mm256_load_ps(b.e1x), e1y = _mm256_load_ps(b.e1y),
               e1z = _mm256_load_ps(b.e1z);
  const __m256 e2x = _mm256_load_ps(b.e2x), e2y = _mm256_load_ps(b.e2y),
               e2z = _mm256_load_ps(b.e2z);
  const __m256 px = _mm256_sub_ps(_mm256_mul_ps(dy, e2z), _mm256_mul_ps(e2y, dz));
  const __m256 py = _mm256_sub_ps(_mm256_mul_ps(dz, e2x), _mm256_mul_ps(e2z, dx));
  const __m256 pz = _mm256_sub_ps(_mm256_mul_ps(dx, e2y), _mm256_mul_ps(e2x, dy));
  const __m256 det = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(e1x, px), _mm256_mul_ps(e1y, py)),
                                   _mm256_mul_ps(e1z, pz));
  const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
  const __m256 sx = _mm256_sub_ps(_mm256_set1_ps(ray.origin.x), _mm256_load_ps(b.v0x));
  const __m256 sy = _mm256_sub_ps(_mm256_set1_ps(ray.origin.y), _mm256_load_ps(b.v0y));
  const __m256 sz = _mm256_sub_ps(_mm256_set1_ps(ray.origin.z), _mm256_load_ps(b.v0z));
  const __m256 u =
      _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(sx, px), _mm256_mul_ps(sy, py)),
                                  _mm256_mul_ps(sz, pz)),
                    inv_det);
  const __m256 qx = _mm256_sub_ps(_mm256_mul_ps(sy, e1z), _mm256_mul_ps(e1y, sz));
  const __m256 qy = _mm256_sub_ps(_mm256_mul_ps(sz, e1x), _mm256_mul_ps(e1z, sx));
  const __m256 qz = _mm256_sub_ps(_mm256_mul_ps(sx, e1y), _mm256_mul_ps(e1x, sy));
  const __m256 v =
      _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, qx), _mm256_mul_ps(dy, qy)),
                                  _mm256_mul_ps(dz, qz)),
                    inv_det);
  const __m256 t =
      _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(e2x, qx), _mm256_mul_ps(e2y, qy)),
                                  _mm256_mul_ps(e2z, qz)),
                    inv_det);
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  __m256 ok = _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ);
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(u, zero, _CMP_GE_OQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(u, one, _CMP_LE_OQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(v, zero, _CMP_GE_OQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(_mm256_add_ps(u, v), one, _CMP_LE_OQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(t, _mm256_set1_ps(ray.tmin), _CMP_GE_OQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(t, _mm256_set1_ps(ray.tmax), _CMP_LE_OQ));
  uint32_t mask = static_cast<uint32_t>(_mm256_movemask_ps(ok));
  if (!mask || !best) return mask != 0;
  alignas(32) float ts[kWidth], us[kWidth], vs[kWidth];
  _mm256_store_ps(ts, t);
  _mm256_store_ps(us, u);
  _mm256_store_ps(vs, v);
  while (mask) {
    const int l = std::countr_zero(mask);
    mask &= mask - 1;
    offer(*best, ts[l], us[l], vs[l], b.prim[l]);
  }
  return true;
}
#endif

}  // namespace tritrace::bvh
