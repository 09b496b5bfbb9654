// Single-ray traversal of the eight-wide BVH. Box tests use the robust slab test of Ize, "Robust
// BVH Ray Traversal" (JCGT 2013): far distances are scaled up by 1 + 2 gamma(3), so rounding can
// only make a box look bigger and the BVH never misses a triangle that the kernel would hit.
#include "tritrace/accel/bvh/bvh_accel.h"

#include "tritrace/accel/bvh/block_kernels.h"
#include "tritrace/accel/bvh/convex_groups.h"
#include "tritrace/accel/bvh/packet_traversal.h"
#include "tritrace/accel/bvh/ray_box.h"
#include "tritrace/accel/bvh/traversal_stack.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
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
                                                   const TriangleArrays& tris,
                                                   [[maybe_unused]] const Ray& ray,
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

// The children of a node (groups: its entry of bvh::child_groups) that hold only triangles of
// group `skip`, as a mask of slots.
[[gnu::always_inline]] inline uint32_t skipped_children(const bvh::ChildGroups& groups,
                                                        uint32_t skip) {
#if defined(__AVX2__)
  const __m256i g = _mm256_load_si256(reinterpret_cast<const __m256i*>(groups.group));
  return static_cast<uint32_t>(_mm256_movemask_ps(
      _mm256_castsi256_ps(_mm256_cmpeq_epi32(g, _mm256_set1_epi32(static_cast<int>(skip))))));
#else
  uint32_t mask = 0;
  for (int c = 0; c < kWidth; ++c) mask |= (groups.group[c] == skip ? 1u : 0u) << c;
  return mask;
#endif
}

// The group ray i of a batch may skip (bvh::skip_group); kNoGroup for every ray where `skipping`
// is false (the batch came without origins, or the mesh has no convex group: BvhAccel::skips).
[[gnu::always_inline]] inline uint32_t batch_skip_group(const bvh::ConvexGroups& convex,
                                                        bool skipping,
                                                        std::span<const uint32_t> origins,
                                                        std::span<const Ray> rays, size_t i) {
  return skipping ? bvh::skip_group(convex.faces, convex.flat, origins[i], &rays[i].dir.x)
                  : bvh::kNoGroup;
}

#if defined(__AVX2__)
// Rays are screened against the root in chunks of this many (see root_survivors).
inline constexpr size_t kRootChunk = 64;

// Eight rays' rows (origin, dir, tmin, tmax: a Ray is eight floats) in, their columns out: ox, oy,
// oz, dx, dy, dz, tmin, tmax, one ray per lane.
static_assert(sizeof(Ray) == 8 * sizeof(float));
[[gnu::always_inline]] inline void transpose8(__m256 r[8]) {
  const __m256 a0 = _mm256_unpacklo_ps(r[0], r[1]), a1 = _mm256_unpackhi_ps(r[0], r[1]);
  const __m256 a2 = _mm256_unpacklo_ps(r[2], r[3]), a3 = _mm256_unpackhi_ps(r[2], r[3]);
  const __m256 a4 = _mm256_unpacklo_ps(r[4], r[5]), a5 = _mm256_unpackhi_ps(r[4], r[5]);
  const __m256 a6 = _mm256_unpacklo_ps(r[6], r[7]), a7 = _mm256_unpackhi_ps(r[6], r[7]);
  const __m256 b0 = _mm256_shuffle_ps(a0, a2, 0x44), b1 = _mm256_shuffle_ps(a0, a2, 0xEE);
  const __m256 b2 = _mm256_shuffle_ps(a1, a3, 0x44), b3 = _mm256_shuffle_ps(a1, a3, 0xEE);
  const __m256 b4 = _mm256_shuffle_ps(a4, a6, 0x44), b5 = _mm256_shuffle_ps(a4, a6, 0xEE);
  const __m256 b6 = _mm256_shuffle_ps(a5, a7, 0x44), b7 = _mm256_shuffle_ps(a5, a7, 0xEE);
  r[0] = _mm256_permute2f128_ps(b0, b4, 0x20);
  r[1] = _mm256_permute2f128_ps(b1, b5, 0x20);
  r[2] = _mm256_permute2f128_ps(b2, b6, 0x20);
  r[3] = _mm256_permute2f128_ps(b3, b7, 0x20);
  r[4] = _mm256_permute2f128_ps(b0, b4, 0x31);
  r[5] = _mm256_permute2f128_ps(b1, b5, 0x31);
  r[6] = _mm256_permute2f128_ps(b2, b6, 0x31);
  r[7] = _mm256_permute2f128_ps(b3, b7, 0x31);
}

// The rays in [begin, end) (at most kRootChunk) that meet a child box of the root, leaving out the
// children of the group each ray may skip as its traversal leaves them out: their indices in
// `survivors` and skip groups in `skips`; returns how many. Every other ray hits nothing, as its
// traversal would find after the same root test. On an open scene most bounce and shadow rays
// leave past every root box (scenes/sky.json: two thirds of its shadow rays), and each paid its
// per-ray set-up and a root test of 150-200 instructions; here eight rays are tested at once, one
// per lane, child after child (docs/PERFORMANCE.md, issue 27). Each lane does box_setup's and
// intersect_boxes's operations in their order on the same operands (the near plane chosen by the
// inverse direction's sign bit, the padded origins, max and min with the same NaN operand), so a
// ray survives exactly when its own root test meets a child. kClosest: the interval the closest
// hit tests, [tmin, min(Hit{}.t, tmax)]; else the any hit's [tmin, tmax]. Watertight kernel only
// (the only one that skips groups).
template <bool kClosest>
size_t root_survivors(const WideBvh& tree, const bvh::ChildGroups* groups,
                      const bvh::ConvexGroups& convex, bool skipping,
                      std::span<const uint32_t> origins, std::span<const Ray> rays, size_t begin,
                      size_t end, uint32_t* survivors, uint32_t* skips) {
  const WideNode& root = tree.nodes[0];
  const float* lo[3] = {root.lo_x, root.lo_y, root.lo_z};
  const float* hi[3] = {root.hi_x, root.hi_y, root.hi_z};
  const uint32_t* child_group = skipping ? groups[0].group : nullptr;
  size_t n = 0;
  for (size_t first = begin; first < end; first += 8) {
    const size_t count = std::min<size_t>(8, end - first);
    // A short chunk's missing rows repeat its last ray; their lanes are dropped below.
    __m256 r[8];
    for (size_t k = 0; k < 8; ++k) {
      r[k] = _mm256_loadu_ps(&rays[first + std::min(k, count - 1)].origin.x);
    }
    transpose8(r);
    alignas(32) uint32_t skip[8];
    for (size_t k = 0; k < 8; ++k) {
      skip[k] =
          k < count ? batch_skip_group(convex, skipping, origins, rays, first + k) : bvh::kNoGroup;
    }
    const __m256i skip_v = _mm256_load_si256(reinterpret_cast<const __m256i*>(skip));
    const __m256i no_group = _mm256_set1_epi32(static_cast<int>(bvh::kNoGroup));
    const __m256 skips_any = _mm256_castsi256_ps(
        _mm256_xor_si256(_mm256_cmpeq_epi32(skip_v, no_group), _mm256_set1_epi32(-1)));
    // traceable(): a finite origin and direction (x - x is 0 exactly for finite x) and tmin <=
    // tmax.
    __m256 finite = _mm256_cmp_ps(r[6], r[7], _CMP_LE_OQ);
    for (int a = 0; a < 6; ++a) {
      finite = _mm256_and_ps(
          finite, _mm256_cmp_ps(_mm256_sub_ps(r[a], r[a]), _mm256_setzero_ps(), _CMP_EQ_OQ));
    }
    // box_setup: the inverse direction, the padding 2^-20 max |o|, the origins moved by it.
    const __m256 sign_bit = _mm256_set1_ps(-0.0f);
    const __m256 largest = _mm256_max_ps(
        _mm256_max_ps(_mm256_andnot_ps(sign_bit, r[0]), _mm256_andnot_ps(sign_bit, r[1])),
        _mm256_andnot_ps(sign_bit, r[2]));
    const __m256 pad = _mm256_mul_ps(_mm256_set1_ps(bvh::kOriginPadding), largest);
    __m256 inv[3], origin_near[3], origin_far[3];
    for (int a = 0; a < 3; ++a) {
      inv[a] = _mm256_div_ps(_mm256_set1_ps(1.0f), r[3 + a]);
      const __m256 signed_pad = _mm256_or_ps(pad, _mm256_and_ps(inv[a], sign_bit));
      origin_near[a] = _mm256_add_ps(r[a], signed_pad);
      origin_far[a] = _mm256_sub_ps(r[a], signed_pad);
    }
    const __m256 tmax = kClosest ? _mm256_min_ps(_mm256_set1_ps(Hit{}.t), r[7]) : r[7];
    __m256 alive = _mm256_setzero_ps();
    for (int c = 0; c < kWidth; ++c) {
      __m256 tn = r[6], tf = tmax;
      for (int a = 0; a < 3; ++a) {
        const __m256 l = _mm256_set1_ps(lo[a][c]), h = _mm256_set1_ps(hi[a][c]);
        const __m256 near_plane = _mm256_blendv_ps(l, h, inv[a]);
        const __m256 far_plane = _mm256_blendv_ps(h, l, inv[a]);
        const __m256 nd = _mm256_mul_ps(_mm256_sub_ps(near_plane, origin_near[a]), inv[a]);
        const __m256 fd = _mm256_mul_ps(_mm256_sub_ps(far_plane, origin_far[a]), inv[a]);
        tn = _mm256_max_ps(nd, tn);
        tf = _mm256_min_ps(fd, tf);
      }
      tf = _mm256_mul_ps(tf, _mm256_set1_ps(bvh::kFarScale));
      __m256 hit = _mm256_cmp_ps(tn, tf, _CMP_LE_OQ);
      if (child_group != nullptr) {
        const __m256 skipped = _mm256_and_ps(
            skips_any, _mm256_castsi256_ps(_mm256_cmpeq_epi32(
                           skip_v, _mm256_set1_epi32(static_cast<int>(child_group[c])))));
        hit = _mm256_andnot_ps(skipped, hit);
      }
      alive = _mm256_or_ps(alive, hit);
    }
    const uint32_t bits = static_cast<uint32_t>(_mm256_movemask_ps(_mm256_and_ps(alive, finite))) &
                          ((1u << count) - 1u);
    for (size_t k = 0; k < count; ++k) {
      survivors[n] = static_cast<uint32_t>(first + k);
      skips[n] = skip[k];
      n += (bits >> k) & 1u;
    }
    // Where the chunk's first eight rays all meet a root box, the rest most likely do too (rays
    // starting inside a closed room, scenes/glass.json's): they are traversed unscreened, which
    // costs their traversal nothing and spares the screen (glass.json's bounce rays took 5% longer
    // screened).
    if (first == begin && n == count) {
      for (size_t i = first + count; i < end; ++i, ++n) {
        survivors[n] = static_cast<uint32_t>(i);
        skips[n] = batch_skip_group(convex, skipping, origins, rays, i);
      }
      return n;
    }
  }
  return n;
}
#endif

// A ray leaving a convex group may skip it (bvh/convex_groups.h): with kSkip, the children that
// hold only group `skip` (groups: the tree's bvh::child_groups) are left out at every node.
template <Kernel K, int Kz, bool kSkip = false>
Hit closest_hit_from(const WideBvh& tree, const TriangleArrays& tris, const Ray& ray,
                     const RayBoxSetup& setup, const PreparedRay<K>& prepared,
                     [[maybe_unused]] const bvh::ChildGroups* groups = nullptr,
                     [[maybe_unused]] uint32_t skip = bvh::kNoGroup) {
  Hit best;
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
      if constexpr (kSkip) mask &= ~skipped_children(groups[ref], skip);
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
// With skip != bvh::kNoGroup, the children holding only that group are left out (groups: the
// tree's bvh::child_groups). One function for both, called from one place per loop: with a call
// for each case GCC's inline-unit-growth limit left the per-ray set-up out of line, and a ray with
// no group to skip took a third longer on sky.json (docs/PERFORMANCE.md, issue 27).
template <Kernel K>
Hit closest_hit(const WideBvh& tree, const TriangleArrays& tris, const Ray& ray,
                [[maybe_unused]] const bvh::ChildGroups* groups = nullptr,
                [[maybe_unused]] uint32_t skip = bvh::kNoGroup) {
  if (tree.nodes.empty() || !traceable(ray)) return Hit{};
  const PreparedRay<K> prepared(ray);
  const RayBoxSetup setup = box_setup(ray);
  [[maybe_unused]] const bool skips = skip != bvh::kNoGroup;
#if defined(__AVX2__)
  if constexpr (K == Kernel::kWatertight) {
    switch (prepared.watertight().kz) {
      case 0:
        return skips ? closest_hit_from<K, 0, true>(tree, tris, ray, setup, prepared, groups, skip)
                     : closest_hit_from<K, 0>(tree, tris, ray, setup, prepared);
      case 1:
        return skips ? closest_hit_from<K, 1, true>(tree, tris, ray, setup, prepared, groups, skip)
                     : closest_hit_from<K, 1>(tree, tris, ray, setup, prepared);
      default:
        return skips ? closest_hit_from<K, 2, true>(tree, tris, ray, setup, prepared, groups, skip)
                     : closest_hit_from<K, 2>(tree, tris, ray, setup, prepared);
    }
  }
#endif
  // Other kernels (for comparison only) skip nothing: fewer instantiations, so that the compiler
  // keeps inlining the per-ray set-up above (GCC's inline-unit-growth limit).
  return closest_hit_from<K, -1>(tree, tris, ray, setup, prepared);
}

#if defined(__AVX2__)
// closest_hit of the watertight kernel for a ray whose dominant axis (watertight_axis) is Kz, with
// kSkip where it has a group to skip: for loops that sort their rays by both, so that choosing
// the instantiation is not a branch per ray that the predictor cannot learn.
template <int Kz, bool kSkip>
Hit closest_hit_axis(const WideBvh& tree, const TriangleArrays& tris, const Ray& ray,
                     const bvh::ChildGroups* groups, uint32_t skip) {
  if (!traceable(ray)) return Hit{};
  // One division for both set-ups: the box test's inverse direction is the kernel's 1 / dir[Kz].
  const RayBoxSetup setup = box_setup(ray);
  const PreparedRay<Kernel::kWatertight> prepared(
      prepare_watertight_axis<Kz>(ray, setup.inv_dir[Kz]));
  assert(watertight_axis(ray.dir) == Kz);
  return closest_hit_from<Kernel::kWatertight, Kz, kSkip>(tree, tris, ray, setup, prepared, groups,
                                                          skip);
}
#endif

// Node and leaf-block visits of a traversal (BvhAccel's probe of its shadow rays).
struct StepCount {
  uint64_t nodes = 0, blocks = 0;
};

// Steps: the node and block visits are added to *steps (kCounted only; the same traversal). With
// kSkip, as closest_hit_from: the children holding only group `skip` are left out.
template <Kernel K, bool kCounted, bool kSkip>
bool any_hit_from(const WideBvh& tree, const TriangleArrays& tris, const Ray& ray,
                  [[maybe_unused]] StepCount* steps,
                  [[maybe_unused]] const bvh::ChildGroups* groups, [[maybe_unused]] uint32_t skip) {
  const RayBoxSetup setup = box_setup(ray);
  uint32_t stack[kStackSize];
  int sp = 0;
  uint32_t ref = 0;
  alignas(32) float tnear[kWidth];
  // The kernel's per-ray work is done at the first leaf block: most shadow rays of an open scene
  // (scenes/sky.json's) end in the nodes, and the set-up's division and permutation were a tenth
  // of their time (docs/PERFORMANCE.md, issue 27).
  std::optional<PreparedRay<K>> prepared;
  for (;;) {
    if constexpr (kCounted) ++((ref & kLeafBit) ? steps->blocks : steps->nodes);
    if (ref & kLeafBit) {
      if (!prepared) prepared.emplace(ray);
      if (intersect_block<K>(tree.blocks[ref & ~kLeafBit], tris, ray, *prepared, nullptr)) {
        return true;
      }
    } else {
      const WideNode& node = tree.nodes[ref];
      uint32_t mask = intersect_boxes(node, setup, ray.tmin, ray.tmax, tnear);
      if constexpr (kSkip) mask &= ~skipped_children(groups[ref], skip);
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

// As closest_hit: one function whether or not a group is skipped.
template <Kernel K, bool kCounted = false>
bool any_hit(const WideBvh& tree, const TriangleArrays& tris, const Ray& ray,
             StepCount* steps = nullptr, const bvh::ChildGroups* groups = nullptr,
             uint32_t skip = bvh::kNoGroup) {
  if (tree.nodes.empty() || !traceable(ray)) return false;
  if constexpr (K == Kernel::kWatertight) {
    if (skip != bvh::kNoGroup) {
      return any_hit_from<K, kCounted, true>(tree, tris, ray, steps, groups, skip);
    }
  }
  return any_hit_from<K, kCounted, false>(tree, tris, ray, steps, groups, skip);
}

#if defined(__AVX2__)
// Calls trace.template operator()<Kz, kSkip>(j) for each survivor j < n of a chunk
// (root_survivors), sorted into six lists by the watertight kernel's dominant axis Kz of its ray
// and by whether it skips a group (skip[j] != bvh::kNoGroup), so that choosing one of the six
// instantiations of a traversal is not a branch per ray, which the predictor cannot learn on
// incoherent rays. Each ray's answer is its own whatever the order.
template <typename Trace>
[[gnu::always_inline]] inline void for_each_by_axis(std::span<const Ray> rays,
                                                    const uint32_t* survivors, const uint32_t* skip,
                                                    size_t n, const Trace& trace) {
  uint32_t sorted[6][kRootChunk];
  size_t sizes[6] = {};
  for (size_t j = 0; j < n; ++j) {
    const int b = 2 * watertight_axis(rays[survivors[j]].dir) + (skip[j] != bvh::kNoGroup);
    sorted[b][sizes[b]++] = static_cast<uint32_t>(j);
  }
  const auto run = [&]<int Kz, bool kSkip>() {
    constexpr int b = 2 * Kz + (kSkip ? 1 : 0);
    for (size_t q = 0; q < sizes[b]; ++q) trace.template operator()<Kz, kSkip>(sorted[b][q]);
  };
  run.template operator()<0, false>();
  run.template operator()<0, true>();
  run.template operator()<1, false>();
  run.template operator()<1, true>();
  run.template operator()<2, false>();
  run.template operator()<2, true>();
}
#endif

// Trees at most this big trace incoherent queries as packets too (see intersect_incoherent). Not
// tuned: cornell-area's 6 KiB tree was measured, nothing between that and 1 MiB.
inline constexpr size_t kIncoherentPacketBytes = size_t{64} << 10;

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

// The box test's per-ray constants (RayBoxSetup) as eight-lane vectors, kept in a ray's slot:
// the interleaved steps read them as memory operands rather than broadcasting nine scalars again
// at every node, since a slot's state does not stay in registers from one step to the next.
struct WideBoxSetup {
  __m256 origin_near[3], origin_far[3], inv_dir[3];
  __m256 tmin, tmax;
  int near_off[3], far_off[3];
};

inline void wide_box_setup(const Ray& ray, WideBoxSetup& w) {
  const RayBoxSetup s = box_setup(ray);
  for (int a = 0; a < 3; ++a) {
    w.origin_near[a] = _mm256_set1_ps(s.origin_near[a]);
    w.origin_far[a] = _mm256_set1_ps(s.origin_far[a]);
    w.inv_dir[a] = _mm256_set1_ps(s.inv_dir[a]);
    w.near_off[a] = s.near_off[a];
    w.far_off[a] = s.far_off[a];
  }
  w.tmin = _mm256_set1_ps(ray.tmin);
  w.tmax = _mm256_set1_ps(ray.tmax);
}

// bvh::intersect_boxes with the constants above, operation for operation (the same boxes hit,
// the same entry distances).
[[gnu::always_inline]] inline uint32_t intersect_boxes(const WideNode& node, const WideBoxSetup& s,
                                                       __m256 tmax, float* tnear) {
  const float* base = node.lo_x;
  __m256 tn = s.tmin;
  __m256 tf = tmax;
  for (int a = 0; a < 3; ++a) {
    const __m256 n = _mm256_mul_ps(
        _mm256_sub_ps(_mm256_load_ps(base + s.near_off[a]), s.origin_near[a]), s.inv_dir[a]);
    const __m256 f = _mm256_mul_ps(
        _mm256_sub_ps(_mm256_load_ps(base + s.far_off[a]), s.origin_far[a]), s.inv_dir[a]);
    tn = _mm256_max_ps(n, tn);  // returns tn when n is NaN
    tf = _mm256_min_ps(f, tf);
  }
  tf = _mm256_mul_ps(tf, _mm256_set1_ps(bvh::kFarScale));
  _mm256_store_ps(tnear, tn);
  return static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ)));
}

// Asks for every cache line of a node or a block (bvh::prefetch): a node (224 bytes on a 32-byte
// boundary) spans the lines at +0, +64, +128 and +192, a block (320 bytes, on a 64-byte boundary
// in the big trees that interleave) those and +256. The address is computed from the leaf bit
// without a select, which the compiler made a branch (unpredictable on incoherent rays).
struct TreeBases {
  const char* base[2];  // the nodes, the blocks
};

[[gnu::always_inline]] inline void prefetch(const TreeBases& t, uint32_t ref) {
  const size_t leaf = ref >> 31;
  const size_t bytes = sizeof(WideNode) + leaf * (sizeof(TriangleBlock) - sizeof(WideNode));
  const char* p = t.base[leaf] + size_t{ref & ~kLeafBit} * bytes;
  __builtin_prefetch(p);
  __builtin_prefetch(p + 64);
  __builtin_prefetch(p + 128);
  __builtin_prefetch(p + 192);
  __builtin_prefetch(p + (leaf << 8));
}

// Both stacks start above kStackFloor entries naming the root, so that the step can
// prefetch the top kPrefetchDepth entries without asking how many there are (the root stays in
// the caches).
inline constexpr int kPrefetchDepth = 2;
inline constexpr int kStackFloor = kPrefetchDepth;

// For each eight-bit mask, the indices of its set bits in increasing order, one per byte: the
// permutation that packs a node's hit children into the lowest lanes.
inline constexpr std::array<uint64_t, 256> kCompress = [] {
  std::array<uint64_t, 256> table{};
  for (uint32_t mask = 0; mask < 256; ++mask) {
    int n = 0;
    for (uint32_t i = 0; i < 8; ++i) {
      if (mask >> i & 1u) table[mask] |= uint64_t{i} << (8 * n++);
    }
  }
  return table;
}();

// One slot of the interleaved closest-hit traversal: a ray's state between its steps.
struct ClosestRay {
  WideBoxSetup setup;
  WatertightRay wt;
  Hit best;
  float tmax;
  uint32_t ref;
  int sp;
  uint32_t index;
  StackEntry stack[kStackFloor + kStackSize + kWidth];
};

// The same for the any-hit traversal. The stack has room for a whole node's eight children
// stored at once above the deepest entry.
struct AnyRay {
  WideBoxSetup setup;
  WatertightRay wt;
  uint32_t ref;
  int sp;
  uint32_t index;
  uint32_t stack[kStackFloor + kStackSize + kWidth];
};

// Pops the next entry for ray s, skipping those beyond its hit; false when none is left.
[[gnu::always_inline]] inline bool closest_pop(const TreeBases& bases, ClosestRay& s) {
  do {
    if (s.sp == kStackFloor) return false;
    --s.sp;
  } while (s.stack[s.sp].key > s.best.t);
  s.ref = s.stack[s.sp].ref;
  // The entry below is the next to be popped, perhaps at this ray's next step (when s.ref is a
  // leaf): asked for now, it has a whole round of the other slots' steps to arrive. At the push
  // only the top kPrefetchDepth entries were asked for, and the deeper ones waited on memory when
  // popped (the floor's root entries keep the index valid).
  prefetch(bases, s.stack[s.sp - 1].ref);
  return true;
}

// One step of closest_hit_from for ray s: a leaf block, or nodes, or a leaf block and then nodes.
// Returns false once the ray is done (s.best is its answer).
template <int Kz>
[[gnu::always_inline]] inline bool closest_step(const WideBvh& tree, const TreeBases& bases,
                                                ClosestRay& s) {
  if (s.ref & kLeafBit) {
    bvh::block_watertight_axis<Kz>(tree.blocks[s.ref & ~kLeafBit], s.wt, &s.best);
    // A popped node goes on in this step rather than the next: it was asked for a round ago or
    // more (at its push or at the pop before), so it has mostly arrived, and the switch to the
    // next slot and back is saved. A popped leaf waits for its own step.
    if (!closest_pop(bases, s)) return false;
    if (s.ref & kLeafBit) return true;
  }
  // Nodes until one has a hit child or a leaf is next: a node none of whose children is hit pops
  // the next entry, a node asked for a round ago or more, and goes on with it in this step.
  for (;;) {
    const WideNode& node = tree.nodes[s.ref];
    alignas(32) float tnear[kWidth];
    const uint32_t mask =
        intersect_boxes(node, s.setup, _mm256_set1_ps(std::min(s.best.t, s.tmax)), tnear);
    if (mask) {
      // One hit child is traversed next without touching the stack. Several are stacked in their
      // places by entry distance, farthest deepest (push_nearest_last_ranked), and the nearest is
      // traversed next. The bitonic network that stacked them without a branch on how many there
      // are (a bitonic network, a13075e) won 4% on random rays but lost 5% (terrain:1m) to 12%
      // (terrain:10m) on the path tracer's bounce rays in the tiles' order, where a single hit
      // child is common and the branch predictable (docs/PERFORMANCE.md, issue 27).
      if (std::has_single_bit(mask)) {
        s.ref = node.child[std::countr_zero(mask)];
        prefetch(bases, s.ref);
        return true;
      }
      assert(s.sp + kWidth <= kStackFloor + kStackSize + kWidth);
      StackEntry* top = s.stack + s.sp;
      const int n = push_nearest_last_ranked(node, mask, tnear, top);
      for (int k = 1; k <= kPrefetchDepth; ++k) prefetch(bases, top[n - k].ref);
      s.sp += n - 1;
      s.ref = top[n - 1].ref;
      return true;
    }
    if (!closest_pop(bases, s)) return false;
    if (s.ref & kLeafBit) return true;
  }
}

// One step of any_hit for ray s. Returns false once the ray is done; `hit` says how.
template <int Kz>
[[gnu::always_inline]] inline bool any_step(const WideBvh& tree, const TreeBases& bases, AnyRay& s,
                                            bool& hit) {
  if (s.ref & kLeafBit) {
    if (bvh::block_watertight_occluded<Kz>(tree.blocks[s.ref & ~kLeafBit], s.wt)) {
      hit = true;
      return false;
    }
    // As in closest_step: a popped node goes on in this step (it was asked for at its push).
    if (s.sp == kStackFloor) {
      hit = false;
      return false;
    }
    s.ref = s.stack[--s.sp];
    if (s.ref & kLeafBit) return true;
  }
  {
    const WideNode& node = tree.nodes[s.ref];
    alignas(32) float tnear[kWidth];
    const uint32_t mask = intersect_boxes(node, s.setup, s.setup.tmax, tnear);
    // The hit children pushed in slot order (the order a loop over the mask bits pushed them) by
    // one permutation and one store, and the next entries to be popped prefetched: no branch on
    // how many children were hit, which the predictor cannot learn on incoherent rays.
    assert(s.sp + kWidth <= kStackFloor + kStackSize + kWidth);
    const __m256i children = _mm256_load_si256(reinterpret_cast<const __m256i*>(node.child));
    const __m256i order =
        _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<int64_t>(kCompress[mask])));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(s.stack + s.sp),
                        _mm256_permutevar8x32_epi32(children, order));
    s.sp += std::popcount(mask);
    for (int k = 1; k <= kPrefetchDepth; ++k) prefetch(bases, s.stack[s.sp - k]);
  }
  if (s.sp == kStackFloor) {
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

// bvh::traceable on one load: the six coordinates finite and tmin <= tmax.
[[gnu::always_inline]] inline bool traceable_wide(const Ray& ray) {
  static_assert(sizeof(Ray) == 8 * sizeof(float) && offsetof(Ray, dir) == 3 * sizeof(float) &&
                offsetof(Ray, tmin) == 6 * sizeof(float));
  const __m256 v = _mm256_loadu_ps(&ray.origin.x);
  const __m256 magnitude = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), v);
  const uint32_t finite = static_cast<uint32_t>(_mm256_movemask_ps(_mm256_cmp_ps(
      magnitude, _mm256_set1_ps(std::numeric_limits<float>::infinity()), _CMP_LT_OQ)));
  return (finite & 0x3Fu) == 0x3Fu && ray.tmin <= ray.tmax;
}

// Orders one chunk's rays by dominant axis: order[first[kz] .. first[kz + 1]) for kz = 0, 1, 2,
// and order[first[3] .. first[4]) the rays that hit nothing by definition (see traceable), which
// the caller answers.
struct ChunkOrder {
  uint16_t order[kChunk];
  size_t first[5];
  WatertightRay wt[kChunk];
};

inline void order_chunk(std::span<const Ray> rays, ChunkOrder& c) {
  size_t count[4] = {0, 0, 0, 0};
  uint8_t axis[kChunk];
  for (size_t i = 0; i < rays.size(); ++i) {
    c.wt[i] = prepare_watertight(rays[i]);
    axis[i] = traceable_wide(rays[i]) ? static_cast<uint8_t>(c.wt[i].kz) : 3;
    ++count[axis[i]];
  }
  c.first[0] = 0;
  for (int a = 0; a < 4; ++a) c.first[a + 1] = c.first[a] + count[a];
  size_t at[4] = {c.first[0], c.first[1], c.first[2], c.first[3]};
  for (size_t i = 0; i < rays.size(); ++i) c.order[at[axis[i]]++] = static_cast<uint16_t>(i);
}

template <int Kz>
void closest_interleaved(const WideBvh& tree, std::span<const Ray> rays, const ChunkOrder& c,
                         ClosestRay* slots, std::span<Hit> hits) {
  const TreeBases bases{{reinterpret_cast<const char*>(tree.nodes.data()),
                         reinterpret_cast<const char*>(tree.blocks.data())}};
  interleave(
      slots, c.order + c.first[Kz], c.first[Kz + 1] - c.first[Kz],
      [&](ClosestRay& s, uint32_t i) {
        const Ray& ray = rays[i];
        wide_box_setup(ray, s.setup);
        s.wt = c.wt[i];
        s.best = Hit{};
        s.tmax = ray.tmax;
        s.ref = 0;
        s.sp = kStackFloor;
        s.index = i;
      },
      [&](ClosestRay& s) { return closest_step<Kz>(tree, bases, s); },
      [&](ClosestRay& s) { hits[s.index] = s.best; });
}

template <int Kz>
void any_interleaved(const WideBvh& tree, std::span<const Ray> rays, const ChunkOrder& c,
                     AnyRay* slots, std::span<uint8_t> occluded) {
  const TreeBases bases{{reinterpret_cast<const char*>(tree.nodes.data()),
                         reinterpret_cast<const char*>(tree.blocks.data())}};
  bool hit = false;
  interleave(
      slots, c.order + c.first[Kz], c.first[Kz + 1] - c.first[Kz],
      [&](AnyRay& s, uint32_t i) {
        const Ray& ray = rays[i];
        wide_box_setup(ray, s.setup);
        s.wt = c.wt[i];
        s.ref = 0;
        s.sp = kStackFloor;
        s.index = i;
      },
      [&](AnyRay& s) { return any_step<Kz>(tree, bases, s, hit); },
      [&](AnyRay& s) { occluded[s.index] = hit ? 1 : 0; });
}

void closest_hits_interleaved(const WideBvh& tree, std::span<const Ray> rays, std::span<Hit> hits) {
  ChunkOrder c;
  ClosestRay slots[kInFlight];
  for (ClosestRay& s : slots) std::fill_n(s.stack, kStackFloor, StackEntry{0, 0.0f});  // the root
  for (size_t first = 0; first < rays.size(); first += kChunk) {
    const size_t n = std::min(kChunk, rays.size() - first);
    const std::span<const Ray> chunk = rays.subspan(first, n);
    const std::span<Hit> out = hits.subspan(first, n);
    order_chunk(chunk, c);
    for (size_t k = c.first[3]; k < c.first[4]; ++k) out[c.order[k]] = Hit{};
    closest_interleaved<0>(tree, chunk, c, slots, out);
    closest_interleaved<1>(tree, chunk, c, slots, out);
    closest_interleaved<2>(tree, chunk, c, slots, out);
  }
}

void any_hits_interleaved(const WideBvh& tree, std::span<const Ray> rays,
                          std::span<uint8_t> occluded) {
  ChunkOrder c;
  AnyRay slots[kInFlight];
  for (AnyRay& s : slots) std::fill_n(s.stack, kStackFloor, 0u);  // the root
  for (size_t first = 0; first < rays.size(); first += kChunk) {
    const size_t n = std::min(kChunk, rays.size() - first);
    const std::span<const Ray> chunk = rays.subspan(first, n);
    const std::span<uint8_t> out = occluded.subspan(first, n);
    order_chunk(chunk, c);
    for (size_t k = c.first[3]; k < c.first[4]; ++k) out[c.order[k]] = 0;
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

// How a tree's incoherent queries are traced, for each of BvhAccel's trees: as packets where
// packets are on and the tree is tiny (it stays in L1, and packets of even unrelated rays share
// its few nodes and leaves).
static bool incoherent_as_packets(const bvh::WideBvh& tree, bool packets) {
  return packets && tree.node_bytes() + tree.block_bytes() <= kIncoherentPacketBytes;
}
#if defined(__AVX2__)
// Interleaved (several rays in flight) where a ray waits on memory; a tree that stays in the
// caches is traversed faster one ray at a time (see docs/PERFORMANCE.md, issue 27).
static bool interleaves_incoherent(const bvh::WideBvh& tree, Kernel kernel,
                                   BvhTraversal traversal) {
  return kernel == Kernel::kWatertight && !tree.nodes.empty() &&
         (traversal == BvhTraversal::kSingleInterleaved ||
          tree.node_bytes() + tree.block_bytes() >= kInterleaveBytes);
}
#endif

BvhAccel::BvhAccel(const TriangleMesh& mesh, Kernel kernel, const bvh::BuildConfig& config,
                   BvhTraversal traversal)
    : BvhAccel(mesh, bvh::build_wide_bvh(mesh, config), kernel, traversal) {
  if (bvh::wants_incoherent_closest_tree(config) && !bvh_.nodes.empty()) {
    closest_ = bvh::build_wide_bvh(mesh, bvh::incoherent_closest_config(config));
    closest_packets_ = incoherent_as_packets(closest_, packets_);
#if defined(__AVX2__)
    closest_interleave_ = interleaves_incoherent(closest_, kernel_, traversal);
#endif
    // Shadow rays took 1.25x less time through the second tree on scenes/sky.json but 1.15x more on
    // scenes/glass.json, whose rays to a small light pass more of its looser leaf boxes: which
    // tree serves a scene's rays is counted on a sample of them (occluded_tree()).
    probes_occluded_ = !incoherent_packets_;
    // Packets of shadow rays to one small light (scenes/glass.json) took 1.5x less time than single
    // rays, packets of rays from all over three spheres towards the sun (scenes/sky.json) 1.2-1.6x
    // more (docs/PERFORMANCE.md, issue 27): counted on the sample too.
    probes_packets_ = packets_;
    node_price_ = config.traversal_cost;
    block_price_ = config.block_cost;
    // Rays leaving a convex mesh skip it (bvh/convex_groups.h): on scenes/sky.json two thirds of
    // the bounce rays leave a sphere for the sky, and took the tree's depth in steps to find that
    // they hit nothing, being inside the boxes of their own sphere's subtrees.
    convex_ = bvh::find_convex_groups(mesh);
    if (convex_.count() > 0) {
      fine_groups_ = bvh::child_groups(bvh_, convex_.faces);
      closest_groups_ = bvh::child_groups(closest_, convex_.faces);
    }
  }
}

BvhAccel::BvhAccel(const TriangleMesh& mesh, bvh::WideBvh tree, Kernel kernel,
                   BvhTraversal traversal)
    : mesh_(mesh),
      bvh_(std::move(tree)),
      kernel_(kernel),
      packets_(traversal == BvhTraversal::kAuto && bvh::has_packet_kernel(kernel)),
      incoherent_packets_(incoherent_as_packets(bvh_, packets_)) {
#if defined(__AVX2__)
  // Decided here for both constructors (GeometrySet's big meshes interleave too).
  interleave_ = interleaves_incoherent(bvh_, kernel_, traversal);
#endif
  closest_packets_ = incoherent_packets_;
  closest_interleave_ = interleave_;
}

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
  intersect_incoherent_from(rays, {}, hits);
}

void BvhAccel::intersect_incoherent_from(std::span<const Ray> rays,
                                         std::span<const uint32_t> origins,
                                         std::span<Hit> hits) const {
  // On closest_tree(), whose flags closest_packets_ and closest_interleave_ are.
  const bvh::WideBvh& tree = closest_tree();
  // A tree this small stays in L1, and packets of even unrelated rays share its few nodes and
  // leaves: on cornell-area the path tracer's bounce and shadow rays as packets took 5-8% less of
  // a frame's CPU time (docs/PERFORMANCE.md, issue 27); either kind alone, 0-1%. Packets are
  // closest_packets_ only when packets_ is set.
  if constexpr (bvh::kPacketSize > 0) {
    if (closest_packets_) {
      for_each_packet(rays, hits, [&](auto packet, auto out) {
        bvh::intersect_packet(tree, kernel_, packet, out);
      });
      return;
    }
  }
#if defined(__AVX2__)
  if (closest_interleave_ && rays.size() > 1) {
    closest_hits_interleaved(tree, rays, hits);
    return;
  }
#endif
  with_kernel(kernel_, [&]<Kernel K>() {
    const TriangleArrays tris = mesh_.arrays();
    const bool skipping = skips(origins, rays.size());
    const bvh::ChildGroups* groups =
        closest_.nodes.empty() ? fine_groups_.data() : closest_groups_.data();
#if defined(__AVX2__)
    if constexpr (K == Kernel::kWatertight) {
      if (tree.nodes.empty()) {
        std::fill(hits.begin(), hits.end(), Hit{});
        return;
      }
      uint32_t survivors[kRootChunk], skip[kRootChunk];
      for (size_t begin = 0; begin < rays.size(); begin += kRootChunk) {
        const size_t end = std::min(rays.size(), begin + kRootChunk);
        const size_t n = root_survivors<true>(tree, groups, convex_, skipping, origins, rays, begin,
                                              end, survivors, skip);
        std::fill(hits.begin() + begin, hits.begin() + end, Hit{});
        for_each_by_axis(rays, survivors, skip, n, [&]<int Kz, bool kSkip>(uint32_t j) {
          hits[survivors[j]] =
              closest_hit_axis<Kz, kSkip>(tree, tris, rays[survivors[j]], groups, skip[j]);
        });
      }
      return;
    }
#endif
    for (size_t i = 0; i < rays.size(); ++i) {
      const uint32_t skip = batch_skip_group(convex_, skipping, origins, rays, i);
      hits[i] = closest_hit<K>(tree, tris, rays[i], groups, skip);
    }
  });
}

void BvhAccel::occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  occluded_incoherent_from(rays, {}, occluded);
}

void BvhAccel::occluded_incoherent_from(std::span<const Ray> rays,
                                        std::span<const uint32_t> origins,
                                        std::span<uint8_t> occluded) const {
  if constexpr (bvh::kPacketSize > 0) {
    if (incoherent_packets_) {
      BvhAccel::occluded(rays, occluded);
      return;
    }
  }
  if (probes_occluded_) {
    static thread_local uint64_t calls = 0;
    if (calls++ % kOccludedProbeEvery == 0) {
      probe_occluded(rays, origins, occluded);
      return;
    }
  }
  const int choice = occluded_choice_.load(std::memory_order_relaxed);
  const bool coarse = (choice & kCoarse) != 0;
  const bvh::WideBvh& tree = coarse ? closest_ : bvh_;
  if constexpr (bvh::kPacketSize > 0) {
    if (choice & kPackets) {
      for_each_packet(rays, occluded, [&](auto packet, auto out) {
        bvh::occluded_packet(tree, kernel_, packet, out);
      });
      return;
    }
  }
#if defined(__AVX2__)
  if ((coarse ? closest_interleave_ : interleave_) && rays.size() > 1) {
    any_hits_interleaved(tree, rays, occluded);
    return;
  }
#endif
  with_kernel(kernel_, [&]<Kernel K>() {
    const TriangleArrays tris = mesh_.arrays();
    const bool skipping = skips(origins, rays.size());
    const bvh::ChildGroups* groups = coarse ? closest_groups_.data() : fine_groups_.data();
#if defined(__AVX2__)
    if constexpr (K == Kernel::kWatertight) {
      if (tree.nodes.empty()) {
        std::fill(occluded.begin(), occluded.end(), uint8_t{0});
        return;
      }
      uint32_t survivors[kRootChunk], skip[kRootChunk];
      for (size_t begin = 0; begin < rays.size(); begin += kRootChunk) {
        const size_t end = std::min(rays.size(), begin + kRootChunk);
        const size_t n = root_survivors<false>(tree, groups, convex_, skipping, origins, rays,
                                               begin, end, survivors, skip);
        std::fill(occluded.begin() + begin, occluded.begin() + end, uint8_t{0});
        for (size_t j = 0; j < n; ++j) {
          occluded[survivors[j]] =
              any_hit<K>(tree, tris, rays[survivors[j]], nullptr, groups, skip[j]) ? 1 : 0;
        }
      }
      return;
    }
#endif
    for (size_t i = 0; i < rays.size(); ++i) {
      const uint32_t skip = batch_skip_group(convex_, skipping, origins, rays, i);
      occluded[i] = any_hit<K>(tree, tris, rays[i], nullptr, groups, skip) ? 1 : 0;
    }
  });
}

// Traces `rays` through both trees one at a time, and as packets where probes_packets_, counting
// the work, and once kOccludedProbeRays rays have been counted (by any thread) chooses the way
// whose work so far, priced as the SAH prices it, costs least; tree() one ray at a time on a tie.
// Counts from threads that probe at once may land in either choice.
void BvhAccel::probe_occluded(std::span<const Ray> rays, std::span<const uint32_t> origins,
                              std::span<uint8_t> occluded) const {
  StepCount steps[2];
  const bool skipping = skips(origins, rays.size());
  with_kernel(kernel_, [&]<Kernel K>() {
    const TriangleArrays tris = mesh_.arrays();
    for (size_t i = 0; i < rays.size(); ++i) {
      // Counted as the single rays go: skipping what the ray leaves where it may.
      const uint32_t skip = batch_skip_group(convex_, skipping, origins, rays, i);
      occluded[i] =
          any_hit<K, true>(bvh_, tris, rays[i], &steps[0], fine_groups_.data(), skip) ? 1 : 0;
      [[maybe_unused]] const bool same =
          any_hit<K, true>(closest_, tris, rays[i], &steps[1], closest_groups_.data(), skip);
      assert(same == (occluded[i] != 0));
    }
  });
  for (int t = 0; t < 2; ++t) {
    probe_nodes_[t].fetch_add(steps[t].nodes, std::memory_order_relaxed);
    probe_blocks_[t].fetch_add(steps[t].blocks, std::memory_order_relaxed);
  }
  // Packets cost 1.5-2x single rays on scenes/sky.json's shadow rays, so they are probed in one
  // probe in kPacketProbeEvery only, their counts weighted by as much.
  static thread_local uint64_t probes = 0;
  if constexpr (bvh::kPacketSize > 0) {
    if (probes_packets_ && probes++ % kPacketProbeEvery == 0) {
      const bvh::WideBvh* trees[2] = {&bvh_, &closest_};
      std::array<uint8_t, bvh::kPacketSize> answers{};
      for (int t = 0; t < 2; ++t) {
        bvh::PacketSteps work;
        for_each_packet(rays, occluded, [&](auto packet, auto out) {
          const std::span<uint8_t> got(answers.data(), packet.size());
          bvh::occluded_packet_counted(*trees[t], kernel_, packet, got, &work);
          assert(std::equal(got.begin(), got.end(), out.begin(),
                            [](uint8_t a, uint8_t b) { return (a != 0) == (b != 0); }));
          (void)out;
        });
        probe_box_tests_[t].fetch_add(kPacketProbeEvery * work.box_tests,
                                      std::memory_order_relaxed);
        probe_leaf_tests_[t].fetch_add(
            kPacketProbeEvery * (work.lane_blocks + work.packet_triangles),
            std::memory_order_relaxed);
      }
    }
  }
  if (probe_rays_.fetch_add(rays.size(), std::memory_order_relaxed) + rays.size() <
      kOccludedProbeRays) {
    return;
  }
  auto count = [](const std::atomic<uint64_t>& c) {
    return static_cast<double>(c.load(std::memory_order_relaxed));
  };
  int best = kFine;
  double best_cost = 0.0;
  for (int t = 0; t < 2; ++t) {
    const double single =
        node_price_ * count(probe_nodes_[t]) + block_price_ * count(probe_blocks_[t]);
    const double packets = kPacketBoxPrice * node_price_ * count(probe_box_tests_[t]) +
                           block_price_ * count(probe_leaf_tests_[t]);
    const int way[2] = {t == 1 ? kCoarse : kFine, (t == 1 ? kCoarse : kFine) | kPackets};
    const double cost[2] = {single, packets};
    for (int p = 0; p < (probes_packets_ ? 2 : 1); ++p) {
      if ((t == 0 && p == 0) || cost[p] < best_cost) {
        best = way[p];
        best_cost = cost[p];
      }
    }
  }
  occluded_choice_.store(best, std::memory_order_relaxed);
}

}  // namespace tritrace
