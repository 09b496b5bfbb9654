// One ray against a whole triangle block (the BVH's leaf): shared by the single-ray traversal and
// by the packet traversal, which hands it the few rays of a packet that reach a leaf.
#pragma once

#include <bit>
#include <cstdint>
#include <glm/vec3.hpp>

#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/hit.h"
#include "tritrace/geometry/intersect.h"
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
// intersect_moller_trumbore's; the edges v1 - v0 and v2 - v0 are the mesh's e1 and e2 bit for bit.
inline bool block_moller_trumbore(const TriangleBlock& b, const Ray& ray, Hit* best) {
  const __m256 dx = _mm256_set1_ps(ray.dir.x), dy = _mm256_set1_ps(ray.dir.y),
               dz = _mm256_set1_ps(ray.dir.z);
  const __m256 v0x = _mm256_load_ps(b.vertex[0][0]), v0y = _mm256_load_ps(b.vertex[0][1]),
               v0z = _mm256_load_ps(b.vertex[0][2]);
  const __m256 e1x = _mm256_sub_ps(_mm256_load_ps(b.vertex[1][0]), v0x),
               e1y = _mm256_sub_ps(_mm256_load_ps(b.vertex[1][1]), v0y),
               e1z = _mm256_sub_ps(_mm256_load_ps(b.vertex[1][2]), v0z);
  const __m256 e2x = _mm256_sub_ps(_mm256_load_ps(b.vertex[2][0]), v0x),
               e2y = _mm256_sub_ps(_mm256_load_ps(b.vertex[2][1]), v0y),
               e2z = _mm256_sub_ps(_mm256_load_ps(b.vertex[2][2]), v0z);
  const __m256 px = _mm256_sub_ps(_mm256_mul_ps(dy, e2z), _mm256_mul_ps(e2y, dz));
  const __m256 py = _mm256_sub_ps(_mm256_mul_ps(dz, e2x), _mm256_mul_ps(e2z, dx));
  const __m256 pz = _mm256_sub_ps(_mm256_mul_ps(dx, e2y), _mm256_mul_ps(e2x, dy));
  const __m256 det = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(e1x, px), _mm256_mul_ps(e1y, py)),
                                   _mm256_mul_ps(e1z, pz));
  const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
  const __m256 sx = _mm256_sub_ps(_mm256_set1_ps(ray.origin.x), v0x);
  const __m256 sy = _mm256_sub_ps(_mm256_set1_ps(ray.origin.y), v0y);
  const __m256 sz = _mm256_sub_ps(_mm256_set1_ps(ray.origin.z), v0z);
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

// The first half of the watertight kernel on a block, for a ray whose dominant axis is Kz: the
// sheared, translated corners' z, the edge functions U = edge(c, b), V = edge(a, c),
// W = edge(b, a) with edge(p, q) = p.x q.y - p.y q.x, and the lanes where one of them is exactly 0
// (the ray through an edge or a vertex). Shared by block_watertight_axis (closest hit) and the
// all-crossings traversal (all_hits.cpp); operation for operation the scalar kernel's.
struct BlockEdges {
  __m256 z[3];
  __m256 u, v, w;
  __m256 on_edge;
};

template <int Kz>
[[gnu::always_inline]] inline BlockEdges block_edge_functions(const TriangleBlock& b,
                                                              const WatertightRay& r) {
  constexpr int kKx = (Kz + 1) % 3, kKy = (Kz + 2) % 3;
  const __m256 ox = _mm256_set1_ps(r.ox), oy = _mm256_set1_ps(r.oy), oz = _mm256_set1_ps(r.oz);
  const __m256 sx = _mm256_set1_ps(r.sx), sy = _mm256_set1_ps(r.sy);
  BlockEdges e;
  __m256 x[3], y[3];
  for (int c = 0; c < 3; ++c) {
    const __m256 qx = _mm256_sub_ps(_mm256_load_ps(b.vertex[c][kKx]), ox);
    const __m256 qy = _mm256_sub_ps(_mm256_load_ps(b.vertex[c][kKy]), oy);
    e.z[c] = _mm256_sub_ps(_mm256_load_ps(b.vertex[c][Kz]), oz);
    x[c] = _mm256_sub_ps(qx, _mm256_mul_ps(sx, e.z[c]));
    y[c] = _mm256_sub_ps(qy, _mm256_mul_ps(sy, e.z[c]));
  }
  e.u = _mm256_sub_ps(_mm256_mul_ps(x[2], y[1]), _mm256_mul_ps(y[2], x[1]));
  e.v = _mm256_sub_ps(_mm256_mul_ps(x[0], y[2]), _mm256_mul_ps(y[0], x[2]));
  e.w = _mm256_sub_ps(_mm256_mul_ps(x[1], y[0]), _mm256_mul_ps(y[1], x[0]));
  const __m256 zero = _mm256_setzero_ps();
  e.on_edge = _mm256_or_ps(
      _mm256_or_ps(_mm256_cmp_ps(e.u, zero, _CMP_EQ_OQ), _mm256_cmp_ps(e.v, zero, _CMP_EQ_OQ)),
      _mm256_cmp_ps(e.w, zero, _CMP_EQ_OQ));
  return e;
}

// The watertight kernel (intersect_watertight in geometry/intersect.h) on eight triangles at once,
// for one ray whose dominant axis is Kz: the same shear, edge functions, determinant and distance,
// operation for operation, so every lane's (t, u, v) is the scalar kernel's bit for bit. A lane
// with an edge function of exactly 0 (the ray through an edge or a vertex) needs the scalar
// kernel's exact fallback in double, so it is handed to the scalar kernel itself: rare, and exact
// by construction. Padding lanes (NaN vertices) fail every comparison.
template <int Kz>
inline bool block_watertight_axis(const TriangleBlock& b, const WatertightRay& r, Hit* best) {
  const BlockEdges e = block_edge_functions<Kz>(b, r);
  const __m256 u = e.u, v = e.v, w = e.w, on_edge = e.on_edge;
  const __m256* z = e.z;
  const __m256 zero = _mm256_setzero_ps();
  const __m256 nonneg = _mm256_and_ps(
      _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_GE_OQ), _mm256_cmp_ps(v, zero, _CMP_GE_OQ)),
      _mm256_cmp_ps(w, zero, _CMP_GE_OQ));
  const __m256 nonpos = _mm256_and_ps(
      _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_LE_OQ), _mm256_cmp_ps(v, zero, _CMP_LE_OQ)),
      _mm256_cmp_ps(w, zero, _CMP_LE_OQ));
  // Most blocks a ray reaches hold no triangle it passes through: leave before the division.
  if (_mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(nonneg, nonpos), on_edge)) == 0) return false;
  const __m256 det = _mm256_add_ps(_mm256_add_ps(u, v), w);
  const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
  const __m256 t =
      _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(u, z[0]), _mm256_mul_ps(v, z[1])),
                                  _mm256_mul_ps(w, z[2])),
                    _mm256_mul_ps(_mm256_set1_ps(r.sz), inv_det));
  __m256 ok = _mm256_andnot_ps(on_edge, _mm256_or_ps(nonneg, nonpos));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(t, _mm256_set1_ps(r.tmin), _CMP_GE_OQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(t, _mm256_set1_ps(r.tmax), _CMP_LE_OQ));
  uint32_t mask = static_cast<uint32_t>(_mm256_movemask_ps(ok));
  uint32_t exact = static_cast<uint32_t>(_mm256_movemask_ps(on_edge));
  bool any = mask != 0;
  if (any && !best) return true;
  if (exact) [[unlikely]] {
    for (; exact; exact &= exact - 1) {
      const int l = std::countr_zero(exact);
      const glm::vec3 p0(b.vertex[0][0][l], b.vertex[0][1][l], b.vertex[0][2][l]);
      const glm::vec3 p1(b.vertex[1][0][l], b.vertex[1][1][l], b.vertex[1][2][l]);
      const glm::vec3 p2(b.vertex[2][0][l], b.vertex[2][1][l], b.vertex[2][2][l]);
      TriangleHit h;
      if (!detail::intersect_watertight_axis<Kz>(r, p0, p1, p2, h)) continue;
      if (!best) return true;
      offer(*best, h.t, h.u, h.v, b.prim[l]);
      any = true;
    }
  }
  if (!mask) return any;
  alignas(32) float ts[kWidth], us[kWidth], vs[kWidth];
  _mm256_store_ps(ts, t);
  _mm256_store_ps(us, _mm256_mul_ps(v, inv_det));
  _mm256_store_ps(vs, _mm256_mul_ps(w, inv_det));
  while (mask) {
    const int l = std::countr_zero(mask);
    mask &= mask - 1;
    offer(*best, ts[l], us[l], vs[l], b.prim[l]);
  }
  return true;
}

// block_watertight_axis with best == nullptr (any hit, for occlusion): the same arithmetic, so
// the same answer, without what a closest hit needs (u and v, the per-lane offers). Kept out of
// line: inlined into the interleaved any-hit step it made that step 20% slower
// (docs/PERFORMANCE.md, issue 27).
template <int Kz>
[[gnu::noinline]] bool block_watertight_occluded(const TriangleBlock& b, const WatertightRay& r) {
  const BlockEdges e = block_edge_functions<Kz>(b, r);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 nonneg = _mm256_and_ps(
      _mm256_and_ps(_mm256_cmp_ps(e.u, zero, _CMP_GE_OQ), _mm256_cmp_ps(e.v, zero, _CMP_GE_OQ)),
      _mm256_cmp_ps(e.w, zero, _CMP_GE_OQ));
  const __m256 nonpos = _mm256_and_ps(
      _mm256_and_ps(_mm256_cmp_ps(e.u, zero, _CMP_LE_OQ), _mm256_cmp_ps(e.v, zero, _CMP_LE_OQ)),
      _mm256_cmp_ps(e.w, zero, _CMP_LE_OQ));
  const __m256 inside = _mm256_or_ps(nonneg, nonpos);
  if (_mm256_movemask_ps(_mm256_or_ps(inside, e.on_edge)) == 0) return false;
  const __m256 det = _mm256_add_ps(_mm256_add_ps(e.u, e.v), e.w);
  const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
  const __m256 t = _mm256_mul_ps(
      _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(e.u, e.z[0]), _mm256_mul_ps(e.v, e.z[1])),
                    _mm256_mul_ps(e.w, e.z[2])),
      _mm256_mul_ps(_mm256_set1_ps(r.sz), inv_det));
  __m256 ok = _mm256_andnot_ps(e.on_edge, inside);
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(t, _mm256_set1_ps(r.tmin), _CMP_GE_OQ));
  ok = _mm256_and_ps(ok, _mm256_cmp_ps(t, _mm256_set1_ps(r.tmax), _CMP_LE_OQ));
  if (_mm256_movemask_ps(ok) != 0) return true;
  for (uint32_t exact = static_cast<uint32_t>(_mm256_movemask_ps(e.on_edge)); exact;
       exact &= exact - 1) {
    const int l = std::countr_zero(exact);
    const glm::vec3 p0(b.vertex[0][0][l], b.vertex[0][1][l], b.vertex[0][2][l]);
    const glm::vec3 p1(b.vertex[1][0][l], b.vertex[1][1][l], b.vertex[1][2][l]);
    const glm::vec3 p2(b.vertex[2][0][l], b.vertex[2][1][l], b.vertex[2][2][l]);
    TriangleHit h;
    if (detail::intersect_watertight_axis<Kz>(r, p0, p1, p2, h)) return true;
  }
  return false;
}

inline bool block_watertight(const TriangleBlock& b, const WatertightRay& r, Hit* best) {
  switch (r.kz) {  // the same way for every leaf of one ray
    case 0:
      return block_watertight_axis<0>(b, r, best);
    case 1:
      return block_watertight_axis<1>(b, r, best);
    default:
      return block_watertight_axis<2>(b, r, best);
  }
}
#endif

}  // namespace tritrace::bvh
