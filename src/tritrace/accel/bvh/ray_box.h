// The single-ray box test of the wide BVH's traversals (closest hit, any hit, every hit): per-ray
// constants and the test of one node's eight child boxes. Boxes use the robust slab test of Ize,
// "Robust BVH Ray Traversal" (JCGT 2013): far distances are scaled up by 1 + 2 gamma(3), so
// rounding can only make a box look bigger and the BVH never misses a triangle that the kernel
// would hit.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/math/ray.h"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace tritrace::bvh {

// Per-ray constants of the box test: the inverse direction, for each axis which of a node's lo/hi
// arrays is the near plane (offsets in floats from WideNode::lo_x), and the origin moved by the
// ray's padding (bvh::origin_padding): forward for near distances, back for far ones, so every box
// is tested as if grown by the padding on each side.
struct RayBoxSetup {
  glm::vec3 origin_near, origin_far, inv_dir;
  int near_off[3], far_off[3];
};

// Always inlined: the single-ray traversals call it once per ray, and GCC's inline-unit-growth
// limit left it out of line in bvh_accel.cpp once that file had a traversal variant more.
[[gnu::always_inline]] inline RayBoxSetup box_setup(const Ray& ray) {
  RayBoxSetup s;
  const glm::vec3 mag = glm::abs(ray.origin);
  const float pad = bvh::origin_padding(std::max({mag.x, mag.y, mag.z}));
#if defined(__AVX2__)
  // The three divisions as one: IEEE division rounds each lane exactly as the scalar one would.
  // Without a branch on the direction's signs (three coin tosses per incoherent ray, which GCC
  // made branches when written as selects): each offset and padded origin follows from the sign
  // bit of the inverse component (+-inf for a zero component, by its sign). o + copysign(pad, inv)
  // is o + pad or o - pad, bit for bit (IEEE subtraction adds the negation).
  const __m128 inv =
      _mm_div_ps(_mm_set1_ps(1.0f), _mm_setr_ps(ray.dir.x, ray.dir.y, ray.dir.z, 1.0f));
  const __m128 o = _mm_setr_ps(ray.origin.x, ray.origin.y, ray.origin.z, 0.0f);
  const __m128 signed_pad = _mm_or_ps(_mm_set1_ps(pad), _mm_and_ps(inv, _mm_set1_ps(-0.0f)));
  alignas(16) float on[4], of[4], iv[4];
  _mm_store_ps(on, _mm_add_ps(o, signed_pad));
  _mm_store_ps(of, _mm_sub_ps(o, signed_pad));
  _mm_store_ps(iv, inv);
  const uint32_t negative = static_cast<uint32_t>(_mm_movemask_ps(inv));
  for (int a = 0; a < 3; ++a) {
    const int flip = static_cast<int>((negative >> a) & 1u) * 8;
    s.inv_dir[a] = iv[a];
    s.origin_near[a] = on[a];
    s.origin_far[a] = of[a];
    s.near_off[a] = 16 * a + flip;
    s.far_off[a] = 16 * a + 8 - flip;
  }
#else
  for (int a = 0; a < 3; ++a) s.inv_dir[a] = 1.0f / ray.dir[a];
  for (int a = 0; a < 3; ++a) {
    const int lo = 16 * a, hi = 16 * a + 8;
    const bool negative = std::signbit(s.inv_dir[a]);
    s.near_off[a] = negative ? hi : lo;
    s.far_off[a] = negative ? lo : hi;
    s.origin_near[a] = negative ? ray.origin[a] - pad : ray.origin[a] + pad;
    s.origin_far[a] = negative ? ray.origin[a] + pad : ray.origin[a] - pad;
  }
#endif
  return s;
}

// Bit i set when child i's box meets [tmin, tmax]; tnear[i] is where. A NaN slab distance (origin
// on the slab plane of a parallel ray) drops out of the max/min, which keeps the test conservative.
[[gnu::always_inline]] inline uint32_t intersect_boxes(const WideNode& node, const RayBoxSetup& s,
                                                       float tmin, float tmax, float* tnear) {
  const float* base = node.lo_x;
#if defined(__AVX2__)
  __m256 tn = _mm256_set1_ps(tmin);
  __m256 tf = _mm256_set1_ps(tmax);
  for (int a = 0; a < 3; ++a) {
    const __m256 on = _mm256_set1_ps(s.origin_near[a]), of = _mm256_set1_ps(s.origin_far[a]);
    const __m256 inv = _mm256_set1_ps(s.inv_dir[a]);
    const __m256 n = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(base + s.near_off[a]), on), inv);
    const __m256 f = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(base + s.far_off[a]), of), inv);
    tn = _mm256_max_ps(n, tn);  // returns tn when n is NaN
    tf = _mm256_min_ps(f, tf);
  }
  tf = _mm256_mul_ps(tf, _mm256_set1_ps(kFarScale));
  _mm256_storeu_ps(tnear, tn);
  return static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ)));
#else
  uint32_t mask = 0;
  for (int i = 0; i < kWidth; ++i) {
    float tn = tmin, tf = tmax;
    for (int a = 0; a < 3; ++a) {
      const float n = (base[s.near_off[a] + i] - s.origin_near[a]) * s.inv_dir[a];
      const float f = (base[s.far_off[a] + i] - s.origin_far[a]) * s.inv_dir[a];
      tn = n > tn ? n : tn;
      tf = f < tf ? f : tf;
    }
    tnear[i] = tn;
    if (tn <= tf * kFarScale) mask |= 1u << i;
  }
  return mask;
#endif
}

// Rays with a NaN or infinite component, or an empty interval, hit nothing; rejecting them here
// keeps NaN out of the box tests, where it would make every slot, even empty ones, look hit.
inline bool traceable(const Ray& ray) {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(ray.origin[a]) || !std::isfinite(ray.dir[a])) return false;
  }
  return ray.tmin <= ray.tmax;
}

// Asks for every cache line of a node or a triangle block, without waiting for them. Without a
// branch: whether a child is a node or a leaf is a coin toss to the branch predictor, and a
// mispredicted branch per stacked child cost more than the prefetches themselves. Both start on a
// 32-byte boundary, so a node spans at most 4 lines and a block 6: the lines at 0, 64, 128, 192 and
// the last byte's cover both (a block's last line holds only prim, which the closest hit reads).
[[gnu::always_inline]] inline void prefetch(const WideBvh& tree, uint32_t ref) {
  // Looked up by the leaf bit rather than chosen by it, so that the compiler makes no branch.
  const uint32_t leaf = ref >> 31;
  const char* const base[2] = {reinterpret_cast<const char*>(tree.nodes.data()),
                               reinterpret_cast<const char*>(tree.blocks.data())};
  static constexpr size_t kBytes[2] = {sizeof(WideNode), sizeof(TriangleBlock)};
  static constexpr size_t kFifth[2] = {sizeof(WideNode) - 1, 256};
  const char* p = base[leaf] + size_t{ref & ~kLeafBit} * kBytes[leaf];
  __builtin_prefetch(p);
  __builtin_prefetch(p + 64);
  __builtin_prefetch(p + 128);
  __builtin_prefetch(p + 192);
  __builtin_prefetch(p + kFifth[leaf]);
  __builtin_prefetch(p + kBytes[leaf] - 1);
}

}  // namespace tritrace::bvh
