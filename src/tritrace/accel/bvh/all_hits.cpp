// Every crossing of a ray through the wide BVH: a traversal that never prunes by distance (every
// child box the ray's interval meets is visited), with leaves tested eight triangles at a time by
// the watertight kernel's operations (block_kernels.h); lanes where the ray passes exactly
// through an edge or vertex go to the tie-broken scalar test of geometry/crossing.h.
#include "tritrace/accel/bvh/all_hits.h"

#include <algorithm>
#include <bit>
#include <cassert>

#include "tritrace/accel/bvh/block_kernels.h"
#include "tritrace/accel/bvh/ray_box.h"
#include "tritrace/geometry/crossing.h"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace tritrace::bvh {
namespace {

// Calls emit(t, u, v, prim) for every triangle of the block that the ray crosses; returns how
// many. With kList false, emit is never called and u, v are not computed.
template <int Kz, bool kList, typename Emit>
[[gnu::always_inline]] inline uint32_t block_crossings(const TriangleBlock& b,
                                                       const WatertightRay& r, Emit&& emit) {
  uint32_t found = 0;
#if defined(__AVX2__)
  const BlockEdges e = block_edge_functions<Kz>(b, r);
  const __m256 u = e.u, v = e.v, w = e.w, on_edge = e.on_edge;
  const __m256* z = e.z;
  const __m256 zero = _mm256_setzero_ps();
  // Away from edges no function is 0, so "all > 0 or all < 0" is the kernel's "all >= 0 or all
  // <= 0"; padding lanes (NaN) fail both.
  const __m256 pos = _mm256_and_ps(
      _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_GT_OQ), _mm256_cmp_ps(v, zero, _CMP_GT_OQ)),
      _mm256_cmp_ps(w, zero, _CMP_GT_OQ));
  const __m256 neg = _mm256_and_ps(
      _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_LT_OQ), _mm256_cmp_ps(v, zero, _CMP_LT_OQ)),
      _mm256_cmp_ps(w, zero, _CMP_LT_OQ));
  const __m256 inside = _mm256_or_ps(pos, neg);
  uint32_t exact = static_cast<uint32_t>(_mm256_movemask_ps(on_edge));
  if (_mm256_movemask_ps(inside) != 0) {
    const __m256 det = _mm256_add_ps(_mm256_add_ps(u, v), w);
    const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
    const __m256 t =
        _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(u, z[0]), _mm256_mul_ps(v, z[1])),
                                    _mm256_mul_ps(w, z[2])),
                      _mm256_mul_ps(_mm256_set1_ps(r.sz), inv_det));
    __m256 ok = _mm256_and_ps(inside, _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(t, _mm256_set1_ps(r.tmin), _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(t, _mm256_set1_ps(r.tmax), _CMP_LE_OQ));
    uint32_t mask = static_cast<uint32_t>(_mm256_movemask_ps(ok));
    found += static_cast<uint32_t>(std::popcount(mask));
    if constexpr (kList) {
      if (mask) {
        alignas(32) float ts[kWidth], us[kWidth], vs[kWidth];
        _mm256_store_ps(ts, t);
        _mm256_store_ps(us, _mm256_mul_ps(v, inv_det));
        _mm256_store_ps(vs, _mm256_mul_ps(w, inv_det));
        for (; mask; mask &= mask - 1) {
          const int l = std::countr_zero(mask);
          emit(ts[l], us[l], vs[l], b.prim[l]);
        }
      }
    }
  }
#else
  uint32_t exact = 0;
  for (int l = 0; l < kWidth; ++l) exact |= b.prim[l] != kNoHit ? 1u << l : 0u;
#endif
  for (; exact; exact &= exact - 1) [[unlikely]] {
      const int l = std::countr_zero(exact);
      const glm::vec3 p0(b.vertex[0][0][l], b.vertex[0][1][l], b.vertex[0][2][l]);
      const glm::vec3 p1(b.vertex[1][0][l], b.vertex[1][1][l], b.vertex[1][2][l]);
      const glm::vec3 p2(b.vertex[2][0][l], b.vertex[2][1][l], b.vertex[2][2][l]);
      TriangleHit h;
      if (!detail::crossing_watertight_axis<Kz>(r, p0, p1, p2, h)) continue;
      ++found;
      if constexpr (kList) emit(h.t, h.u, h.v, b.prim[l]);
    }
  return found;
}

// Visits every leaf whose box the ray's interval meets (in no particular order) and sums what
// block_crossings finds there.
template <int Kz, bool kList, typename Emit>
uint32_t crossings_from(const WideBvh& tree, const Ray& ray, const WatertightRay& w, Emit&& emit) {
  const RayBoxSetup setup = box_setup(ray);
  uint32_t stack[kStackSize];
  int sp = 0;
  uint32_t ref = 0;
  uint32_t found = 0;
  alignas(32) float tnear[kWidth];
  for (;;) {
    if (ref & kLeafBit) {
      found += block_crossings<Kz, kList>(tree.blocks[ref & ~kLeafBit], w, emit);
    } else {
      const WideNode& node = tree.nodes[ref];
      uint32_t mask = intersect_boxes(node, setup, ray.tmin, ray.tmax, tnear);
      if (mask) {
        // One child next, the others on the stack.
        ref = node.child[std::countr_zero(mask)];
        for (mask &= mask - 1; mask; mask &= mask - 1) {
          assert(sp < kStackSize);
          const uint32_t child = node.child[std::countr_zero(mask)];
          // Every stacked child will be visited: fetch it while the first is traversed.
          prefetch(tree, child);
          stack[sp++] = child;
        }
        continue;
      }
    }
    if (sp == 0) return found;
    ref = stack[--sp];
  }
}

template <bool kList, typename Emit>
uint32_t crossings(const WideBvh& tree, const Ray& ray, Emit&& emit) {
  if (tree.nodes.empty() || !traceable(ray)) return 0;
  const WatertightRay w = prepare_watertight(ray);
  switch (w.kz) {
    case 0:
      return crossings_from<0, kList>(tree, ray, w, emit);
    case 1:
      return crossings_from<1, kList>(tree, ray, w, emit);
    default:
      return crossings_from<2, kList>(tree, ray, w, emit);
  }
}

struct NoEmit {
  void operator()(float, float, float, uint32_t) const {}
};

// Crossings of one ray are few: insertion sort by (t, prim).
void sort_by_t(Hit* first, Hit* last) {
  // (first + 1 is not a pointer into, or just past, fewer than one element: for none, first may
  // be null, an empty vector's data.)
  if (last - first < 2) return;
  for (Hit* i = first + 1; i < last; ++i) {
    const Hit h = *i;
    Hit* j = i;
    for (; j > first && (h.t < j[-1].t || (h.t == j[-1].t && h.prim < j[-1].prim)); --j) {
      *j = j[-1];
    }
    *j = h;
  }
}

}  // namespace

uint32_t count_crossings(const WideBvh& tree, const Ray& ray) {
  return crossings<false>(tree, ray, NoEmit{});
}

void list_crossings(const WideBvh& tree, const Ray& ray, std::vector<Hit>& out) {
  const size_t first = out.size();
  crossings<true>(tree, ray, [&](float t, float u, float v, uint32_t prim) {
    out.push_back(Hit{t, u, v, prim});
  });
  sort_by_t(out.data() + first, out.data() + out.size());
}

void count_intersections(const WideBvh& tree, std::span<const Ray> rays,
                         std::span<uint32_t> counts) {
  for (size_t i = 0; i < rays.size(); ++i) counts[i] = count_crossings(tree, rays[i]);
}

void list_intersections(const WideBvh& tree, std::span<const Ray> rays, Intersections& out) {
  out.ray_splits.assign(1, 0);
  out.ray_splits.reserve(rays.size() + 1);
  out.hits.clear();
  for (const Ray& ray : rays) {
    list_crossings(tree, ray, out.hits);
    out.ray_splits.push_back(out.hits.size());
  }
}

}  // namespace tritrace::bvh
