// Single-ray traversal of the eight-wide BVH. Box tests use the robust slab test of Ize, "Robust
// BVH Ray Traversal" (JCGT 2013): far distances are scaled up by 1 + 2 gamma(3), so rounding can
// only make a box look bigger and the BVH never misses a triangle that the kernel would hit.
#include "tritrace/accel/bvh/bvh_accel.h"

#include "tritrace/accel/bvh/block_kernels.h"
#include "tritrace/accel/bvh/packet_traversal.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <utility>

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

using bvh::offer;
#if defined(__AVX2__)
using bvh::block_moller_trumbore;
using bvh::block_watertight;
#endif

// Per-ray constants of the box test: the inverse direction, for each axis which of a node's lo/hi
// arrays is the near plane (offsets in floats from WideNode::lo_x), and the origin moved by the
// ray's padding (bvh::origin_padding): forward for near distances, back for far ones, so every box
// is tested as if grown by the padding on each side.
struct RayBoxSetup {
  glm::vec3 origin_near, origin_far, inv_dir;
  int near_off[3], far_off[3];
};

RayBoxSetup box_setup(const Ray& ray) {
  RayBoxSetup s;
  const glm::vec3 mag = glm::abs(ray.origin);
  const float pad = bvh::origin_padding(std::max({mag.x, mag.y, mag.z}));
#if defined(__AVX2__)
  // The three divisions as one: IEEE division rounds each lane exactly as the scalar one would.
  alignas(16) float inv[4];
  _mm_store_ps(inv,
               _mm_div_ps(_mm_set1_ps(1.0f), _mm_setr_ps(ray.dir.x, ray.dir.y, ray.dir.z, 1.0f)));
  s.inv_dir = glm::vec3(inv[0], inv[1], inv[2]);
#else
  for (int a = 0; a < 3; ++a) s.inv_dir[a] = 1.0f / ray.dir[a];
#endif
  for (int a = 0; a < 3; ++a) {
    // inv_dir is +-inf for a zero component, by its sign.
    const int lo = 16 * a, hi = 16 * a + 8;
    const bool negative = std::signbit(s.inv_dir[a]);
    s.near_off[a] = negative ? hi : lo;
    s.far_off[a] = negative ? lo : hi;
    s.origin_near[a] = negative ? ray.origin[a] - pad : ray.origin[a] + pad;
    s.origin_far[a] = negative ? ray.origin[a] + pad : ray.origin[a] - pad;
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

// The other kernels read the triangles from the mesh, through the same PreparedRay and arrays as
// the brute-force loop: the watertight kernel needs the exact vertices (v0 + e1 is not always v1
// in float), which the blocks do not keep.
template <Kernel K>
inline bool block_scalar(const TriangleBlock& b, const TriangleArrays& tris,
                         const PreparedRay<K>& ray, Hit* best) {
  bool any = false;
  for (int l = 0; l < kWidth; ++l) {
    if (b.prim[l] == kNoHit) continue;
    TriangleHit h;
    if (ray.intersect(tris, b.prim[l], h)) {
      if (!best) return true;
      offer(*best, h.t, h.u, h.v, b.prim[l]);
      any = true;
    }
  }
  return any;
}

// With best == nullptr: any hit ends the search (occlusion). Otherwise: the closest hit. `prepared`
// is `ray` with the kernel's per-ray work done once for the whole traversal.
// Kz >= 0: the watertight kernel for a ray whose dominant axis is Kz, chosen once per ray (see
// closest_hit), so that the block test inlines into the traversal loop with no switch per leaf.
template <Kernel K, int Kz = -1>
[[gnu::always_inline]] inline bool intersect_block(const TriangleBlock& b,
                                                   const TriangleArrays& tris, const Ray& ray,
                                                   const PreparedRay<K>& prepared, Hit* best) {
#if defined(__AVX2__)
  if constexpr (K == Kernel::kMollerTrumbore) return block_moller_trumbore(b, ray, best);
  if constexpr (K == Kernel::kWatertight && Kz >= 0) {
    return block_watertight_axis<Kz>(b, prepared.watertight(), best);
  }
  if constexpr (K == Kernel::kWatertight) return block_watertight(b, prepared.watertight(), best);
#endif
  return block_scalar<K>(b, tris, prepared, best);
}

// Rays with a NaN or infinite component, or an empty interval, hit nothing; rejecting them here
// keeps NaN out of the box tests, where it would make every slot, even empty ones, look hit.
inline bool traceable(const Ray& ray) {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(ray.origin[a]) || !std::isfinite(ray.dir[a])) return false;
  }
  return ray.tmin <= ray.tmax;
}

// Asks for every cache line of a node or a triangle block, without waiting for them.
inline void prefetch(const WideBvh& tree, uint32_t ref) {
  const char* p = ref & kLeafBit ? reinterpret_cast<const char*>(&tree.blocks[ref & ~kLeafBit])
                                 : reinterpret_cast<const char*>(&tree.nodes[ref]);
  const size_t bytes = ref & kLeafBit ? sizeof(TriangleBlock) : sizeof(WideNode);
  for (size_t line = 0; line < bytes; line += 64) __builtin_prefetch(p + line);
}

struct StackEntry {
  uint32_t ref;
  float t;
};

template <Kernel K, int Kz>
Hit closest_hit_from(const WideBvh& tree, const TriangleArrays& tris, const Ray& ray,
                     const PreparedRay<K>& prepared) {
  Hit best;
  const RayBoxSetup setup = box_setup(ray);
  StackEntry stack[kStackSize];
  int sp = 0;
  uint32_t ref = 0;
  alignas(32) float tnear[kWidth];
  for (;;) {
    if (ref & kLeafBit) {
      intersect_block<K, Kz>(tree.blocks[ref & ~kLeafBit], tris, ray, prepared, &best);
    } else {
      const WideNode& node = tree.nodes[ref];
      const float tmax = std::min(best.t, ray.tmax);
      uint32_t mask = intersect_boxes(node, setup, ray.tmin, tmax, tnear);
      if (mask) {
        if (std::has_single_bit(mask)) {
          ref = node.child[std::countr_zero(mask)];
          continue;
        }
        // Nearest child next, the others on the stack, farthest deepest: sorted by insertion
        // straight into the stack's top, so nothing is copied.
        assert(sp + std::popcount(mask) <= kStackSize);  // the builder bounds the depth
        StackEntry* top = stack + sp;
        int n = 0;
        while (mask) {
          const int i = std::countr_zero(mask);
          mask &= mask - 1;
          const StackEntry e{node.child[i], tnear[i]};
          int j = n++;
          for (; j > 0 && top[j - 1].t < e.t; --j) top[j] = top[j - 1];
          top[j] = e;
        }
        // The stacked children are fetched from memory while the nearest is traversed: on a
        // big scene most node and leaf visits wait on memory.
        for (int i = 0; i < n - 1; ++i) prefetch(tree, top[i].ref);
        sp += n - 1;
        ref = top[n - 1].ref;
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

// The closest hit of one ray. For the watertight kernel the ray's dominant axis picks one of three
// instantiations, once per ray rather than once per leaf.
template <Kernel K>
Hit closest_hit(const WideBvh& tree, const TriangleArrays& tris, const Ray& ray) {
  if (tree.nodes.empty() || !traceable(ray)) return Hit{};
  const PreparedRay<K> prepared(ray);
#if defined(__AVX2__)
  if constexpr (K == Kernel::kWatertight) {
    switch (prepared.watertight().kz) {
      case 0:
        return closest_hit_from<K, 0>(tree, tris, ray, prepared);
      case 1:
        return closest_hit_from<K, 1>(tree, tris, ray, prepared);
      default:
        return closest_hit_from<K, 2>(tree, tris, ray, prepared);
    }
  }
#endif
  return closest_hit_from<K, -1>(tree, tris, ray, prepared);
}

template <Kernel K>
bool any_hit(const WideBvh& tree, const TriangleArrays& tris, const Ray& ray) {
  if (tree.nodes.empty() || !traceable(ray)) return false;
  const RayBoxSetup setup = box_setup(ray);
  const PreparedRay<K> prepared(ray);
  uint32_t stack[kStackSize];
  int sp = 0;
  uint32_t ref = 0;
  alignas(32) float tnear[kWidth];
  for (;;) {
    if (ref & kLeafBit) {
      if (intersect_block<K>(tree.blocks[ref & ~kLeafBit], tris, ray, prepared, nullptr)) {
        return true;
      }
    } else {
      const WideNode& node = tree.nodes[ref];
      uint32_t mask = intersect_boxes(node, setup, ray.tmin, ray.tmax, tnear);
      while (mask) {
        assert(sp < kStackSize);
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
    : mesh_(mesh),
      bvh_(bvh::build_wide_bvh(mesh, config)),
      kernel_(kernel),
      packets_(traversal == BvhTraversal::kAuto && bvh::has_packet_kernel(kernel)) {}

BvhAccel::BvhAccel(const TriangleMesh& mesh, bvh::WideBvh tree, Kernel kernel,
                   BvhTraversal traversal)
    : mesh_(mesh),
      bvh_(std::move(tree)),
      kernel_(kernel),
      packets_(traversal == BvhTraversal::kAuto && bvh::has_packet_kernel(kernel)) {}

void BvhAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  if constexpr (bvh::kPacketSize > 0) {
    if (packets_) {
      for_each_packet(rays, hits, [&](auto packet, auto out) {
        bvh::intersect_packet(bvh_, kernel_, packet, out);
      });
      return;
    }
  }
  intersect_incoherent(rays, hits);
}

void BvhAccel::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  if constexpr (bvh::kPacketSize > 0) {
    if (packets_) {
      for_each_packet(rays, occluded, [&](auto packet, auto out) {
        bvh::occluded_packet(bvh_, kernel_, packet, out);
      });
      return;
    }
  }
  occluded_incoherent(rays, occluded);
}

void BvhAccel::intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const {
  with_kernel(kernel_, [&]<Kernel K>() {
    const TriangleArrays tris = mesh_.arrays();
    for (size_t i = 0; i < rays.size(); ++i) hits[i] = closest_hit<K>(bvh_, tris, rays[i]);
  });
}

void BvhAccel::occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  with_kernel(kernel_, [&]<Kernel K>() {
    const TriangleArrays tris = mesh_.arrays();
    for (size_t i = 0; i < rays.size(); ++i) occluded[i] = any_hit<K>(bvh_, tris, rays[i]) ? 1 : 0;
  });
}

}  // namespace tritrace
