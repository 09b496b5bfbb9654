// Single-ray traversal of the eight-wide BVH. Box tests use the robust slab test of Ize, "Robust
// BVH Ray Traversal" (JCGT 2013): far distances are scaled up by 1 + 2 gamma(3), so rounding can
// only make a box look bigger and the BVH never misses a triangle that the kernel would hit.
#include "tritrace/accel/bvh/bvh_accel.h"

#include "tritrace/accel/bvh/packet_traversal.h"

#include <algorithm>
#include <bit>
#include <cmath>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace tritrace {
namespace {

using bvh::kLeafBit;
using bvh::kWidth;
using bvh::TriangleBlock;
using bvh::WideBvh;
using bvh::WideNode;

using bvh::kFarScale;
using bvh::kStackSize;

// Per-ray constants of the box test: the inverse direction, and for each axis which of a node's
// lo/hi arrays is the near plane (offsets in floats from WideNode::lo_x).
struct RayBoxSetup {
  glm::vec3 origin, inv_dir;
  int near_off[3], far_off[3];
};

RayBoxSetup box_setup(const Ray& ray) {
  RayBoxSetup s;
  s.origin = ray.origin;
  for (int a = 0; a < 3; ++a) {
    s.inv_dir[a] = 1.0f / ray.dir[a];  // +-inf for a zero component, by its sign
    const int lo = 16 * a, hi = 16 * a + 8;
    const bool negative = std::signbit(s.inv_dir[a]);
    s.near_off[a] = negative ? hi : lo;
    s.far_off[a] = negative ? lo : hi;
  }
  return s;
}

// Bit i set when child i's box meets [tmin, tmax]; tnear[i] is where. A NaN slab distance (origin
// on the slab plane of a parallel ray) drops out of the max/min, which keeps the test conservative.
inline uint32_t intersect_boxes(const WideNode& node, const RayBoxSetup& s, float tmin, float tmax,
                                float* tnear) {
  const float* base = node.lo_x;
#if defined(__AVX2__)
  __m256 tn = _mm256_set1_ps(tmin);
  __m256 tf = _mm256_set1_ps(tmax);
  for (int a = 0; a < 3; ++a) {
    const __m256 o = _mm256_set1_ps(s.origin[a]);
    const __m256 inv = _mm256_set1_ps(s.inv_dir[a]);
    const __m256 n = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(base + s.near_off[a]), o), inv);
    const __m256 f = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(base + s.far_off[a]), o), inv);
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
      const float n = (base[s.near_off[a] + i] - s.origin[a]) * s.inv_dir[a];
      const float f = (base[s.far_off[a] + i] - s.origin[a]) * s.inv_dir[a];
      tn = n > tn ? n : tn;
      tf = f < tf ? f : tf;
    }
    tnear[i] = tn;
    if (tn <= tf * kFarScale) mask |= 1u << i;
  }
  return mask;
#endif
}

// (t, prim) ordered lexicographically: the closer hit wins, and on a tie the earlier triangle, as
// in the brute-force loop.
inline void offer(Hit& best, float t, float u, float v, uint32_t prim) {
  if (t < best.t || (t == best.t && prim < best.prim)) best = {t, u, v, prim};
}

template <Kernel K>
inline bool block_scalar(const TriangleBlock& b, const Ray& ray, Hit* best) {
  bool any = false;
  for (int l = 0; l < kWidth; ++l) {
    if (b.prim[l] == kNoHit) continue;
    const glm::vec3 v0(b.v0x[l], b.v0y[l], b.v0z[l]);
    const glm::vec3 e1(b.e1x[l], b.e1y[l], b.e1z[l]);
    const glm::vec3 e2(b.e2x[l], b.e2y[l], b.e2z[l]);
    TriangleHit h;
    if (intersect_triangle<K>(ray, v0, e1, e2, h)) {
      if (!best) return true;
      offer(*best, h.t, h.u, h.v, b.prim[l]);
      any = true;
    }
  }
  return any;
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

// With best == nullptr: any hit ends the search (occlusion). Otherwise: the closest hit.
template <Kernel K>
inline bool intersect_block(const TriangleBlock& b, const Ray& ray, Hit* best) {
#if defined(__AVX2__)
  if constexpr (K == Kernel::kMollerTrumbore) return block_moller_trumbore(b, ray, best);
#endif
  return block_scalar<K>(b, ray, best);
}

// Rays with a NaN or infinite component, or an empty interval, hit nothing; rejecting them here
// keeps NaN out of the box tests, where it would make every slot, even empty ones, look hit.
inline bool traceable(const Ray& ray) {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(ray.origin[a]) || !std::isfinite(ray.dir[a])) return false;
  }
  return ray.tmin <= ray.tmax;
}

struct StackEntry {
  uint32_t ref;
  float t;
};

template <Kernel K>
Hit closest_hit(const WideBvh& tree, const Ray& ray) {
  Hit best;
  if (tree.nodes.empty() || !traceable(ray)) return best;
  const RayBoxSetup setup = box_setup(ray);
  StackEntry stack[kStackSize];
  int sp = 0;
  uint32_t ref = 0;
  alignas(32) float tnear[kWidth];
  for (;;) {
    if (ref & kLeafBit) {
      intersect_block<K>(tree.blocks[ref & ~kLeafBit], ray, &best);
    } else {
      const WideNode& node = tree.nodes[ref];
      const float tmax = std::min(best.t, ray.tmax);
      uint32_t mask = intersect_boxes(node, setup, ray.tmin, tmax, tnear);
      if (mask) {
        if (std::has_single_bit(mask)) {
          ref = node.child[std::countr_zero(mask)];
          continue;
        }
        // Nearest child next, the others on the stack, farthest deepest.
        StackEntry hits[kWidth];
        int n = 0;
        while (mask) {
          const int i = std::countr_zero(mask);
          mask &= mask - 1;
          StackEntry e{node.child[i], tnear[i]};
          int j = n++;
          for (; j > 0 && hits[j - 1].t < e.t; --j) hits[j] = hits[j - 1];
          hits[j] = e;
        }
        for (int i = 0; i < n - 1; ++i) stack[sp++] = hits[i];
        ref = hits[n - 1].ref;
        continue;
      }
    }
    // Pop, skipping subtrees that start beyond the closest hit so far (ties are kept).
    do {
      if (sp == 0) return best;
      --sp;
    } while (stack[sp].t > best.t);
    ref = stack[sp].ref;
  }
}

template <Kernel K>
bool any_hit(const WideBvh& tree, const Ray& ray) {
  if (tree.nodes.empty() || !traceable(ray)) return false;
  const RayBoxSetup setup = box_setup(ray);
  uint32_t stack[kStackSize];
  int sp = 0;
  uint32_t ref = 0;
  alignas(32) float tnear[kWidth];
  for (;;) {
    if (ref & kLeafBit) {
      if (intersect_block<K>(tree.blocks[ref & ~kLeafBit], ray, nullptr)) return true;
    } else {
      const WideNode& node = tree.nodes[ref];
      uint32_t mask = intersect_boxes(node, setup, ray.tmin, ray.tmax, tnear);
      while (mask) {
        stack[sp++] = node.child[std::countr_zero(mask)];
        mask &= mask - 1;
      }
    }
    if (sp == 0) return false;
    ref = stack[--sp];
  }
}

// Calls fn(rays, out) on consecutive packets of at most bvh::kPacketSize rays.
template <typename Out, typename Fn>
void for_each_packet(std::span<const Ray> rays, std::span<Out> out, Fn&& fn) {
  for (size_t first = 0; first < rays.size(); first += bvh::kPacketSize) {
    const size_t n = std::min<size_t>(bvh::kPacketSize, rays.size() - first);
    fn(rays.subspan(first, n), out.subspan(first, n));
  }
}

}  // namespace

BvhAccel::BvhAccel(const TriangleMesh& mesh, Kernel kernel, const bvh::BuildConfig& config,
                   BvhTraversal traversal)
    : bvh_(bvh::build_wide_bvh(mesh, config)),
      kernel_(kernel),
      packets_(traversal == BvhTraversal::kAuto && bvh::kPacketSize > 0 &&
               kernel == Kernel::kMollerTrumbore) {}

void BvhAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  if constexpr (bvh::kPacketSize > 0) {
    if (packets_) {
      for_each_packet(rays, hits,
                      [&](auto packet, auto out) { bvh::intersect_packet(bvh_, packet, out); });
      return;
    }
  }
  with_kernel(kernel_, [&]<Kernel K>() {
    for (size_t i = 0; i < rays.size(); ++i) hits[i] = closest_hit<K>(bvh_, rays[i]);
  });
}

void BvhAccel::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  if constexpr (bvh::kPacketSize > 0) {
    if (packets_) {
      for_each_packet(rays, occluded,
                      [&](auto packet, auto out) { bvh::occluded_packet(bvh_, packet, out); });
      return;
    }
  }
  with_kernel(kernel_, [&]<Kernel K>() {
    for (size_t i = 0; i < rays.size(); ++i) occluded[i] = any_hit<K>(bvh_, rays[i]) ? 1 : 0;
  });
}

}  // namespace tritrace
