// Single-ray traversal of the eight-wide BVH. Box tests use the robust slab test of Ize, "Robust
// BVH Ray Traversal" (JCGT 2013): far distances are scaled up by 1 + 2 gamma(3), so rounding can
// only make a box look bigger and the BVH never misses a triangle that the kernel would hit.
#include "tritrace/accel/bvh/bvh_accel.h"

#include "tritrace/accel/bvh/block_kernels.h"
#include "tritrace/accel/bvh/packet_traversal.h"
#include "tritrace/accel/bvh/ray_box.h"
#include "tritrace/accel/bvh/traversal_stack.h"

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
using bvh::push_nearest_last;
using bvh::RayBoxSetup;
using bvh::StackEntry;
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

#if defined(__AVX2__)
// push_nearest_last's order (the farthest deepest, equal keys with the lower slot deeper) with each
// child's place counted rather than found by insertion: a child goes above every child with a
// greater key and every lower slot with an equal one. The insertion's comparisons were branches
// on the distances, which the predictor cannot learn on incoherent rays.
[[gnu::always_inline]] inline int push_nearest_last_ranked(const WideNode& node, uint32_t mask,
                                                           const float* tnear, StackEntry* top) {
  const __m256 keys = _mm256_load_ps(tnear);
  for (uint32_t m = mask; m; m &= m - 1) {
    const int i = std::countr_zero(m);
    const __m256 key = _mm256_set1_ps(tnear[i]);
    const uint32_t greater =
        static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(keys, key, _CMP_GT_OQ)));
    const uint32_t equal =
        static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(keys, key, _CMP_EQ_OQ)));
    const int place = std::popcount(greater & mask) + std::popcount(equal & mask & ((1u << i) - 1));
    top[place] = StackEntry{node.child[i], tnear[i]};
  }
  return std::popcount(mask);
}

#endif

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
        // Nearest child next, the others on the stack, farthest deepest: each written straight
        // into its place on the stack, so nothing is copied.
        assert(sp + std::popcount(mask) <= kStackSize);  // the builder bounds the depth
        StackEntry* top = stack + sp;
#if defined(__AVX2__)
        const int n = push_nearest_last_ranked(node, mask, tnear, top);
#else
        const int n = push_nearest_last(node, mask, tnear, top);
#endif
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
    } while (stack[sp].key > best.t);
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

#if defined(__AVX2__)
// Interleaved traversal of a batch of incoherent rays with the watertight kernel. On a big mesh a
// single ray spends most of its time waiting for the next node or leaf block to arrive from
// memory, one fetch after the other. So kInFlight rays are traversed side by side: each ray takes
// one step (one node or one leaf block), asks for the memory of its next step without waiting
// (prefetch) and hands over to the next ray, whose memory has arrived meanwhile. This is the
// "asynchronous memory access chaining" of Kocberber et al., "Asynchronous Memory Access
// Chaining", VLDB 2015, applied to BVH traversal. Every ray is still traversed alone, in the
// order closest_hit_from and any_hit use, so the answers are theirs bit for bit.
inline constexpr int kInFlight = 12;
// Rays are taken in chunks, grouped by their dominant axis (the watertight kernel's kz, a template
// argument of the block test) so that the leaf test has no switch per block.
inline constexpr size_t kChunk = 256;
// Trees at least this big (nodes and blocks) are traversed interleaved.
inline constexpr size_t kInterleaveBytes = size_t{1} << 20;
// Trees at most this big trace incoherent queries as packets too (see intersect_incoherent). Not
// tuned: cornell-area's 6 KiB tree was measured, nothing between that and 1 MiB.
inline constexpr size_t kIncoherentPacketBytes = size_t{64} << 10;

// One slot of the interleaved closest-hit traversal: a ray's state between its steps.
struct ClosestRay {
  RayBoxSetup setup;
  WatertightRay wt;
  Hit best;
  float tmin, tmax;
  uint32_t ref;
  int sp;
  uint32_t index;
  StackEntry stack[kStackSize];
};

// The same for the any-hit traversal.
struct AnyRay {
  RayBoxSetup setup;
  WatertightRay wt;
  float tmin, tmax;
  uint32_t ref;
  int sp;
  uint32_t index;
  uint32_t stack[kStackSize];
};

// One step of closest_hit_from for ray s: a leaf block or a node. Returns false once the ray is
// done (s.best is its answer).
template <int Kz>
[[gnu::always_inline]] inline bool closest_step(const WideBvh& tree, ClosestRay& s) {
  if (s.ref & kLeafBit) {
    bvh::block_watertight_axis<Kz>(tree.blocks[s.ref & ~kLeafBit], s.wt, &s.best);
  } else {
    const WideNode& node = tree.nodes[s.ref];
    alignas(32) float tnear[kWidth];
    uint32_t mask = intersect_boxes(node, s.setup, s.tmin, std::min(s.best.t, s.tmax), tnear);
    if (mask) {
      if (std::has_single_bit(mask)) {
        s.ref = node.child[std::countr_zero(mask)];
        prefetch(tree, s.ref);
        return true;
      }
      assert(s.sp + std::popcount(mask) <= kStackSize);
      StackEntry* top = s.stack + s.sp;
      const int n = push_nearest_last_ranked(node, mask, tnear, top);
      for (int i = 0; i < n; ++i) prefetch(tree, top[i].ref);
      s.sp += n - 1;
      s.ref = top[n - 1].ref;
      return true;
    }
  }
  do {
    if (s.sp == 0) return false;
    --s.sp;
  } while (s.stack[s.sp].key > s.best.t);
  s.ref = s.stack[s.sp].ref;
  return true;
}

// One step of any_hit for ray s. Returns false once the ray is done; `hit` says how.
template <int Kz>
[[gnu::always_inline]] inline bool any_step(const WideBvh& tree, AnyRay& s, bool& hit) {
  if (s.ref & kLeafBit) {
    if (bvh::block_watertight_axis<Kz>(tree.blocks[s.ref & ~kLeafBit], s.wt, nullptr)) {
      hit = true;
      return false;
    }
  } else {
    const WideNode& node = tree.nodes[s.ref];
    alignas(32) float tnear[kWidth];
    uint32_t mask = intersect_boxes(node, s.setup, s.tmin, s.tmax, tnear);
    while (mask) {
      assert(s.sp < kStackSize);
      const uint32_t child = node.child[std::countr_zero(mask)];
      prefetch(tree, child);
      s.stack[s.sp++] = child;
      mask &= mask - 1;
    }
  }
  if (s.sp == 0) {
    hit = false;
    return false;
  }
  s.ref = s.stack[--s.sp];
  return true;
}

// Traces rays[order[0..n)], all with dominant axis Kz, kInFlight at a time. Start(slot, index)
// readies a slot for a ray and Step(slot) advances it (false: done, and Finish(slot) stores it).
template <typename Slot, typename Start, typename Step, typename Finish>
[[gnu::always_inline]] inline void interleave(Slot* slots, const uint16_t* order, size_t n,
                                              Start&& start, Step&& step, Finish&& finish) {
  int live[kInFlight];
  int count = 0;
  size_t next = 0;
  for (; count < kInFlight && next < n; ++count) {
    live[count] = count;
    start(slots[count], order[next++]);
  }
  while (count > 0) {
    for (int k = 0; k < count;) {
      Slot& s = slots[live[k]];
      if (step(s)) {
        ++k;
        continue;
      }
      finish(s);
      if (next < n) {
        start(s, order[next++]);
        ++k;
      } else {
        live[k] = live[--count];
      }
    }
  }
}

// Orders one chunk's traceable rays by dominant axis: order[first[kz] .. first[kz + 1]). Rays
// that hit nothing by definition (see traceable) are left out; the caller answers them.
struct ChunkOrder {
  uint16_t order[kChunk];
  size_t first[4];
  WatertightRay wt[kChunk];
};

inline void order_chunk(std::span<const Ray> rays, ChunkOrder& c) {
  size_t count[3] = {0, 0, 0};
  uint8_t axis[kChunk];
  for (size_t i = 0; i < rays.size(); ++i) {
    c.wt[i] = prepare_watertight(rays[i]);
    axis[i] = traceable(rays[i]) ? static_cast<uint8_t>(c.wt[i].kz) : 3;
    if (axis[i] < 3) ++count[axis[i]];
  }
  c.first[0] = 0;
  for (int a = 0; a < 3; ++a) c.first[a + 1] = c.first[a] + count[a];
  size_t at[3] = {c.first[0], c.first[1], c.first[2]};
  for (size_t i = 0; i < rays.size(); ++i) {
    if (axis[i] < 3) c.order[at[axis[i]]++] = static_cast<uint16_t>(i);
  }
}

template <int Kz>
void closest_interleaved(const WideBvh& tree, std::span<const Ray> rays, const ChunkOrder& c,
                         ClosestRay* slots, std::span<Hit> hits) {
  interleave(
      slots, c.order + c.first[Kz], c.first[Kz + 1] - c.first[Kz],
      [&](ClosestRay& s, uint32_t i) {
        const Ray& ray = rays[i];
        s.setup = box_setup(ray);
        s.wt = c.wt[i];
        s.best = Hit{};
        s.tmin = ray.tmin;
        s.tmax = ray.tmax;
        s.ref = 0;
        s.sp = 0;
        s.index = i;
      },
      [&](ClosestRay& s) { return closest_step<Kz>(tree, s); },
      [&](ClosestRay& s) { hits[s.index] = s.best; });
}

template <int Kz>
void any_interleaved(const WideBvh& tree, std::span<const Ray> rays, const ChunkOrder& c,
                     AnyRay* slots, std::span<uint8_t> occluded) {
  bool hit = false;
  interleave(
      slots, c.order + c.first[Kz], c.first[Kz + 1] - c.first[Kz],
      [&](AnyRay& s, uint32_t i) {
        const Ray& ray = rays[i];
        s.setup = box_setup(ray);
        s.wt = c.wt[i];
        s.tmin = ray.tmin;
        s.tmax = ray.tmax;
        s.ref = 0;
        s.sp = 0;
        s.index = i;
      },
      [&](AnyRay& s) { return any_step<Kz>(tree, s, hit); },
      [&](AnyRay& s) { occluded[s.index] = hit ? 1 : 0; });
}

void closest_hits_interleaved(const WideBvh& tree, std::span<const Ray> rays, std::span<Hit> hits) {
  ChunkOrder c;
  ClosestRay slots[kInFlight];
  for (size_t first = 0; first < rays.size(); first += kChunk) {
    const size_t n = std::min(kChunk, rays.size() - first);
    const std::span<const Ray> chunk = rays.subspan(first, n);
    const std::span<Hit> out = hits.subspan(first, n);
    order_chunk(chunk, c);
    for (size_t i = 0; i < n; ++i) {
      if (!traceable(chunk[i])) out[i] = Hit{};
    }
    closest_interleaved<0>(tree, chunk, c, slots, out);
    closest_interleaved<1>(tree, chunk, c, slots, out);
    closest_interleaved<2>(tree, chunk, c, slots, out);
  }
}

void any_hits_interleaved(const WideBvh& tree, std::span<const Ray> rays,
                          std::span<uint8_t> occluded) {
  ChunkOrder c;
  AnyRay slots[kInFlight];
  for (size_t first = 0; first < rays.size(); first += kChunk) {
    const size_t n = std::min(kChunk, rays.size() - first);
    const std::span<const Ray> chunk = rays.subspan(first, n);
    const std::span<uint8_t> out = occluded.subspan(first, n);
    order_chunk(chunk, c);
    for (size_t i = 0; i < n; ++i) {
      if (!traceable(chunk[i])) out[i] = 0;
    }
    any_interleaved<0>(tree, chunk, c, slots, out);
    any_interleaved<1>(tree, chunk, c, slots, out);
    any_interleaved<2>(tree, chunk, c, slots, out);
  }
}
#endif

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
      packets_(traversal == BvhTraversal::kAuto && bvh::has_packet_kernel(kernel)) {
#if defined(__AVX2__)
  // Interleaving pays where a ray waits on memory; a tree that stays in the caches is traversed
  // faster one ray at a time (see docs/PERFORMANCE.md, issue 27).
  interleave_ = kernel_ == Kernel::kWatertight && !bvh_.nodes.empty() &&
                (traversal == BvhTraversal::kSingleInterleaved ||
                 bvh_.node_bytes() + bvh_.block_bytes() >= kInterleaveBytes);
#endif
  incoherent_packets_ =
      packets_ && bvh_.node_bytes() + bvh_.block_bytes() <= kIncoherentPacketBytes;
}

BvhAccel::BvhAccel(const TriangleMesh& mesh, bvh::WideBvh tree, Kernel kernel,
                   BvhTraversal traversal)
    : mesh_(mesh),
      bvh_(std::move(tree)),
      kernel_(kernel),
      packets_(traversal == BvhTraversal::kAuto && bvh::has_packet_kernel(kernel)),
      incoherent_packets_(packets_ &&
                          bvh_.node_bytes() + bvh_.block_bytes() <= kIncoherentPacketBytes) {}

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
  // A tree this small stays in L1, and packets of even unrelated rays share its few nodes and
  // leaves: on cornell-area the path tracer's bounce and shadow rays as packets took 5-8% less of
  // a frame's CPU time (docs/PERFORMANCE.md, issue 27); either kind alone, 0-1%. Packets are
  // incoherent_packets_ only when packets_ is set, so intersect does not come back here.
  if constexpr (bvh::kPacketSize > 0) {
    if (incoherent_packets_) {
      intersect(rays, hits);
      return;
    }
  }
#if defined(__AVX2__)
  if (interleave_ && rays.size() > 1) {
    closest_hits_interleaved(bvh_, rays, hits);
    return;
  }
#endif
  with_kernel(kernel_, [&]<Kernel K>() {
    const TriangleArrays tris = mesh_.arrays();
    for (size_t i = 0; i < rays.size(); ++i) hits[i] = closest_hit<K>(bvh_, tris, rays[i]);
  });
}

void BvhAccel::occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  if constexpr (bvh::kPacketSize > 0) {
    if (incoherent_packets_) {
      BvhAccel::occluded(rays, occluded);
      return;
    }
  }
#if defined(__AVX2__)
  if (interleave_ && rays.size() > 1) {
    any_hits_interleaved(bvh_, rays, occluded);
    return;
  }
#endif
  with_kernel(kernel_, [&]<Kernel K>() {
    const TriangleArrays tris = mesh_.arrays();
    for (size_t i = 0; i < rays.size(); ++i) occluded[i] = any_hit<K>(bvh_, tris, rays[i]) ? 1 : 0;
  });
}

}  // namespace tritrace
