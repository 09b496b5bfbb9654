// Single-ray traversal of the eight-wide BVH. Box tests use the robust slab test of Ize, "Robust
// BVH Ray Traversal" (JCGT 2013): far distances are scaled up by 1 + 2 gamma(3), so rounding can
// only make a box look bigger and the BVH never misses a triangle that the kernel would hit.
#include "tritrace/accel/bvh/bvh_accel.h"

#include "tritrace/accel/bvh/block_kernels.h"
#include "tritrace/accel/bvh/packet_traversal.h"
#include "tritrace/accel/bvh/ray_box.h"

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

using bvh::box_setup;
using bvh::intersect_boxes;
using bvh::prefetch;
using bvh::RayBoxSetup;
using bvh::traceable;

using bvh::kLeafBit;
using bvh::kWidth;
using bvh::TriangleBlock;
using bvh::WideBvh;
using bvh::WideNode;

using bvh::kStackSize;

using bvh::offer;
#if defined(__AVX2__)
using bvh::block_moller_trumbore;
using bvh::block_watertight;
#endif

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
