// The packet traversal. A child is entered when any active ray of the packet hits its box; the
// packet visits children nearest first (by the nearest ray's entry distance) and skips a stacked
// subtree when every ray already has a hit closer than where that subtree starts.
#include "tritrace/accel/bvh/packet_traversal.h"

#include "tritrace/accel/bvh/block_kernels.h"

#if defined(__AVX2__)

// GCC 12's AVX-512 intrinsics read a deliberately undefined register and warn about it when
// inlined (GCC bug 105593); the warning is about the compiler's own header, not this code.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <limits>

// The lambdas below ask to be inlined ([[gnu::always_inline]] after their parameters): GCC honours
// it; clang (CI's sanitizer builds) ignores it with a warning, and the spelling clang would take
// (__attribute__ there) changes GCC's code for these kernels.
#if defined(__clang__)
#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Wignored-attributes"
#endif

namespace tritrace::bvh {
namespace {

using namespace simd;
constexpr int W = kLanes;
constexpr float kInf = std::numeric_limits<float>::infinity();

// Interval bounds of a packet's origins and inverse directions, splatted for a test of all eight
// children of a node at once. Usable when every active ray has the same direction sign on each axis
// and finite bounds (interval arithmetic over a packet, as in Wald, Boulos and Shirley, "Ray
// Tracing Deformable Scenes Using Dynamic Bounding Volume Hierarchies", ACM TOG 26(1), 2007).
struct Frustum {
  __m256 o_lo[3], o_hi[3], inv_lo[3], inv_hi[3];
  float tmin_lo = 0.0f;
  bool usable = false;
};

struct Packet {
  VF o[3], d[3], inv[3];
  // The origin moved by the lane's padding (origin_padding in wide_bvh.h): forward along the
  // direction for near slab distances, back for far ones, so boxes are tested grown by it.
  VF o_near[3], o_far[3];
  VF tmin, tmax;
  VM negative[3];
  // Per axis: 0 all directions positive, 1 all negative, -1 mixed (then blend per lane).
  int sign[3];
  uint32_t active;
  Frustum frustum;
  // The watertight kernel's per-ray set-up (prepare_watertight), lane by lane, when loaded for it:
  // the origin in the permuted order (kx, ky, kz), the shear (sx, sy, sz), the dominant axis as
  // masks, and that axis when every active lane shares it (else -1: vertices are permuted per
  // lane).
  VF wt_o[3], wt_s[3];
  VM kz_is_1, kz_is_2;
  int kz_uniform = 2;
  // The same set-up stored per lane, for the scalar kernel on single lanes: written the first
  // time a lane needs it (few-ray leaves, exact fallbacks), which most camera packets of a small
  // scene never do.
  mutable bool lanes_stored = false;
  alignas(64) mutable float lane_o[3][W], lane_s[3][W], lane_tmin[W], lane_tmax[W];
  alignas(64) mutable int32_t lane_kz[W];

  void store_lanes() const {
    for (int a = 0; a < 3; ++a) {
      store(lane_o[a], wt_o[a]);
      store(lane_s[a], wt_s[a]);
    }
    store(lane_kz, select(kz_is_2, splat_i(2), select(kz_is_1, splat_i(1), splat_i(0))));
    store(lane_tmin, tmin);
    store(lane_tmax, tmax);
    lanes_stored = true;
  }

  WatertightRay lane_ray(int l) const {
    if (!lanes_stored) store_lanes();
    WatertightRay r;
    r.kz = lane_kz[l];
    r.ox = lane_o[0][l], r.oy = lane_o[1][l], r.oz = lane_o[2][l];
    r.sx = lane_s[0][l], r.sy = lane_s[1][l], r.sz = lane_s[2][l];
    r.tmin = lane_tmin[l];
    r.tmax = lane_tmax[l];
    return r;
  }
};

static_assert(sizeof(Ray) == 8 * sizeof(float) && offsetof(Ray, dir) == 3 * sizeof(float) &&
              offsetof(Ray, tmin) == 6 * sizeof(float) && offsetof(Ray, tmax) == 7 * sizeof(float));

inline VM finite(VF x) {
  return (x - x) == splat(0.0f);
}  // NaN and +-inf give NaN

// Transposes up to W rays into lanes (a Ray is one row of 8 floats). Lanes past the batch, or with
// a non-finite ray or an empty interval, get an empty interval and never hit anything; so do lanes
// that the watertight kernel's set-up rejects (a zero or overflowing direction), as
// prepare_watertight does for a single ray.
template <Kernel K>
Packet load_packet(std::span<const Ray> rays, bool with_frustum) {
  const int count = static_cast<int>(rays.size());
  // A lane past the batch reads this ray: an empty interval.
  static constexpr float kUnused[8] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, kInf, -kInf};
  const float* rows[W];
  for (int l = 0; l < W; ++l) {
    rows[l] = l < count ? reinterpret_cast<const float*>(&rays[static_cast<size_t>(l)]) : kUnused;
  }
  VF column[8];
  transpose_rows_of_8(rows, column);
  Packet p;
  const VF o[3] = {column[0], column[1], column[2]}, d[3] = {column[3], column[4], column[5]};
  const VF tmin = column[6], tmax = column[7];
  VM ok = first_lanes(count) & (tmin <= tmax);
  for (int a = 0; a < 3; ++a) ok = ok & finite(o[a]) & finite(d[a]);

  if constexpr (K == Kernel::kWatertight) {
    // prepare_watertight, lane by lane: the same comparisons, division and product.
    const VF ax = abs(d[0]), ay = abs(d[1]), az = abs(d[2]);
    const VM y_over_x = ay > ax;
    p.kz_is_2 = az > vmax(ax, ay);
    p.kz_is_1 = andnot(p.kz_is_2, y_over_x);
    const VM k1 = p.kz_is_1, k2 = p.kz_is_2;
    // The axis the packet's rays share, if they do (camera rays almost always): then the
    // permutation is a choice of registers, not a select per lane.
    {
      const uint32_t on = bits(ok), one = bits(k1) & on, two = bits(k2) & on;
      p.kz_uniform = two == on ? 2 : one == on ? 1 : (one | two) == 0 ? 0 : -1;
    }
    // kz = 0: (kx, ky) = (1, 2); kz = 1: (2, 0); kz = 2: (0, 1).
    VF dp[3];
    if (p.kz_uniform >= 0) {
      const int kz = p.kz_uniform, kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
      p.wt_o[0] = o[kx], p.wt_o[1] = o[ky], p.wt_o[2] = o[kz];
      dp[0] = d[kx], dp[1] = d[ky], dp[2] = d[kz];
    } else {
      auto permute = [&](const VF v[3], VF out[3]) {
        out[0] = select(k2, v[0], select(k1, v[2], v[1]));
        out[1] = select(k2, v[1], select(k1, v[0], v[2]));
        out[2] = select(k2, v[2], select(k1, v[1], v[0]));
      };
      permute(o, p.wt_o);
      permute(d, dp);
    }
    p.wt_s[2] = splat(1.0f) / dp[2];
    p.wt_s[0] = dp[0] * p.wt_s[2];
    p.wt_s[1] = dp[1] * p.wt_s[2];
    // Lanes the set-up rejects leave the packet; the shared axis, if any, stays shared.
    ok = ok & finite(p.wt_s[0]) & finite(p.wt_s[1]) & finite(p.wt_s[2]) &
         not_equal(p.wt_s[2], splat(0.0f));
  }

  p.active = bits(ok);
  const uint32_t all = (1u << W) - 1;
  VF largest = splat(0.0f);
  for (int a = 0; a < 3; ++a) {
    p.o[a] = select(ok, o[a], splat(0.0f));
    p.d[a] = select(ok, d[a], splat(a == 2 ? 1.0f : 0.0f));
    p.inv[a] = splat(1.0f) / p.d[a];
    p.negative[a] = signbit(p.inv[a]);
    const uint32_t neg = bits(p.negative[a]);
    p.sign[a] = neg == 0 ? 0 : neg == all ? 1 : -1;
    largest = vmax(largest, abs(p.o[a]));
  }
  const VF pad = splat(kOriginPadding) * largest;
  for (int a = 0; a < 3; ++a) {
    // The padding with the sign of the direction: forward for near planes, back for far ones.
    const VF forward = copysign(pad, p.inv[a]);
    p.o_near[a] = p.o[a] + forward;
    p.o_far[a] = p.o[a] - forward;
  }
  p.tmin = select(ok, tmin, splat(kInf));
  p.tmax = select(ok, tmax, splat(-kInf));

  Frustum& f = p.frustum;
  f.usable = with_frustum && p.active != 0;
  const float pad_hi = hmax(select(ok, pad, splat(0.0f)));
  for (int a = 0; a < 3 && f.usable; ++a) {
    // The origins' range widened by the largest padding covers every lane's moved origins.
    const float o_lo = hmin(select(ok, p.o[a], splat(kInf))) - pad_hi;
    const float o_hi = hmax(select(ok, p.o[a], splat(-kInf))) + pad_hi;
    const float inv_lo = hmin(select(ok, p.inv[a], splat(kInf)));
    const float inv_hi = hmax(select(ok, p.inv[a], splat(-kInf)));
    // Finite bounds (a zero direction component has an infinite inverse) of one sign.
    f.usable = p.sign[a] >= 0 && std::isfinite(o_lo) && std::isfinite(o_hi) &&
               std::isfinite(inv_lo) && std::isfinite(inv_hi);
    f.o_lo[a] = _mm256_set1_ps(o_lo);
    f.o_hi[a] = _mm256_set1_ps(o_hi);
    f.inv_lo[a] = _mm256_set1_ps(inv_lo);
    f.inv_hi[a] = _mm256_set1_ps(inv_hi);
  }
  f.tmin_lo = hmin(p.tmin);
  return p;
}

// The packet's frustum against all eight children of `node`: bit c is set when child c's box may be
// hit by some ray of the packet within (tmin, tfar_hi]. Every bound is taken at the ends of the
// intervals; rounding to nearest is monotonic, so each bound holds for the rounded per-ray values
// hit_box computes: a child that hit_box would enter for some ray is never rejected here, so the
// traversal stays exact.
inline uint32_t frustum_hits(const WideNode& node, const Packet& p, float tfar_hi) {
  const Frustum& f = p.frustum;
  const float* lo[3] = {node.lo_x, node.lo_y, node.lo_z};
  const float* hi[3] = {node.hi_x, node.hi_y, node.hi_z};
  __m256 tn = _mm256_set1_ps(f.tmin_lo), tf = _mm256_set1_ps(tfar_hi);
  for (int a = 0; a < 3; ++a) {
    const __m256 near = _mm256_load_ps(p.sign[a] ? hi[a] : lo[a]);
    const __m256 far = _mm256_load_ps(p.sign[a] ? lo[a] : hi[a]);
    const __m256 n0 = _mm256_sub_ps(near, f.o_hi[a]), n1 = _mm256_sub_ps(near, f.o_lo[a]);
    const __m256 f0 = _mm256_sub_ps(far, f.o_hi[a]), f1 = _mm256_sub_ps(far, f.o_lo[a]);
    const __m256 near_lo = _mm256_min_ps(
        _mm256_min_ps(_mm256_mul_ps(n0, f.inv_lo[a]), _mm256_mul_ps(n0, f.inv_hi[a])),
        _mm256_min_ps(_mm256_mul_ps(n1, f.inv_lo[a]), _mm256_mul_ps(n1, f.inv_hi[a])));
    const __m256 far_hi = _mm256_max_ps(
        _mm256_max_ps(_mm256_mul_ps(f0, f.inv_lo[a]), _mm256_mul_ps(f0, f.inv_hi[a])),
        _mm256_max_ps(_mm256_mul_ps(f1, f.inv_lo[a]), _mm256_mul_ps(f1, f.inv_hi[a])));
    tn = _mm256_max_ps(near_lo, tn);
    tf = _mm256_min_ps(far_hi, tf);
  }
  const __m256 hit = _mm256_cmp_ps(tn, _mm256_mul_ps(tf, _mm256_set1_ps(kFarScale)), _CMP_LE_OQ);
  return static_cast<uint32_t>(_mm256_movemask_ps(hit));
}

// The packet against one child box; `tfar` is each ray's current far limit.
inline VM hit_box(const WideNode& node, int c, const Packet& p, VF tfar, VF& tnear) {
  const float lo[3] = {node.lo_x[c], node.lo_y[c], node.lo_z[c]};
  const float hi[3] = {node.hi_x[c], node.hi_y[c], node.hi_z[c]};
  VF tn = p.tmin, tf = tfar;
  for (int a = 0; a < 3; ++a) {
    VF near, far;
    if (p.sign[a] >= 0) {
      near = splat(p.sign[a] ? hi[a] : lo[a]);
      far = splat(p.sign[a] ? lo[a] : hi[a]);
    } else {
      near = select(p.negative[a], splat(hi[a]), splat(lo[a]));
      far = select(p.negative[a], splat(lo[a]), splat(hi[a]));
    }
    tn = vmax((near - p.o_near[a]) * p.inv[a], tn);  // a NaN slab distance leaves tn as it was
    tf = vmin((far - p.o_far[a]) * p.inv[a], tf);
  }
  tnear = tn;
  return tn <= tf * splat(kFarScale);
}

// One triangle of a block against every ray of the packet: `ok` where the kernel reports a hit,
// and for the watertight kernel `exact` where a lane needs the scalar kernel's exact fallback.
struct TriangleHits {
  VM ok;
  VF t, u, v;
  uint32_t exact = 0;
};

// Möller–Trumbore, lane for lane the scalar kernel's operations (intersect_moller_trumbore) in the
// same order; the edges are the mesh's e1 and e2 bit for bit (TriangleBlock).
[[gnu::always_inline]] inline TriangleHits moller_trumbore(const TriangleBlock& b, int l,
                                                           const Packet& p) {
  const float v0[3] = {b.vertex[0][0][l], b.vertex[0][1][l], b.vertex[0][2][l]};
  const VF e1x = splat(b.vertex[1][0][l] - v0[0]), e1y = splat(b.vertex[1][1][l] - v0[1]),
           e1z = splat(b.vertex[1][2][l] - v0[2]);
  const VF e2x = splat(b.vertex[2][0][l] - v0[0]), e2y = splat(b.vertex[2][1][l] - v0[1]),
           e2z = splat(b.vertex[2][2][l] - v0[2]);
  const VF &dx = p.d[0], &dy = p.d[1], &dz = p.d[2];
  const VF px = dy * e2z - e2y * dz;
  const VF py = dz * e2x - e2z * dx;
  const VF pz = dx * e2y - e2x * dy;
  const VF det = (e1x * px + e1y * py) + e1z * pz;
  const VF inv_det = splat(1.0f) / det;
  const VF sx = p.o[0] - splat(v0[0]), sy = p.o[1] - splat(v0[1]), sz = p.o[2] - splat(v0[2]);
  const VF u = ((sx * px + sy * py) + sz * pz) * inv_det;
  const VF qx = sy * e1z - e1y * sz;
  const VF qy = sz * e1x - e1z * sx;
  const VF qz = sx * e1y - e1x * sy;
  const VF v = ((dx * qx + dy * qy) + dz * qz) * inv_det;
  const VF t = ((e2x * qx + e2y * qy) + e2z * qz) * inv_det;
  const VF zero = splat(0.0f), one = splat(1.0f);
  const VM ok = not_equal(det, zero) & (u >= zero) & (u <= one) & (v >= zero) & (u + v <= one) &
                (t >= p.tmin) & (t <= p.tmax);
  return {ok, t, u, v};
}

// The watertight kernel (intersect_watertight), lane for lane the scalar kernel's operations on the
// lane's own set-up. Kz is the dominant axis shared by every lane, or -1 when lanes differ: then
// each lane picks its permutation of the vertex coordinates with selects.
template <int Kz>
[[gnu::always_inline]] inline TriangleHits watertight(const TriangleBlock& b, int l,
                                                      const Packet& p) {
  VF x[3], y[3], z[3];
  for (int c = 0; c < 3; ++c) {
    VF pk[3];  // the vertex in the lane's (kx, ky, kz) order
    if constexpr (Kz >= 0) {
      pk[0] = splat(b.vertex[c][(Kz + 1) % 3][l]);
      pk[1] = splat(b.vertex[c][(Kz + 2) % 3][l]);
      pk[2] = splat(b.vertex[c][Kz][l]);
    } else {
      const VF vx = splat(b.vertex[c][0][l]), vy = splat(b.vertex[c][1][l]),
               vz = splat(b.vertex[c][2][l]);
      pk[0] = select(p.kz_is_2, vx, select(p.kz_is_1, vz, vy));
      pk[1] = select(p.kz_is_2, vy, select(p.kz_is_1, vx, vz));
      pk[2] = select(p.kz_is_2, vz, select(p.kz_is_1, vy, vx));
    }
    z[c] = pk[2] - p.wt_o[2];
    x[c] = (pk[0] - p.wt_o[0]) - p.wt_s[0] * z[c];
    y[c] = (pk[1] - p.wt_o[1]) - p.wt_s[1] * z[c];
  }
  const VF u = x[2] * y[1] - y[2] * x[1];
  const VF v = x[0] * y[2] - y[0] * x[2];
  const VF w = x[1] * y[0] - y[1] * x[0];
  const VF zero = splat(0.0f);
  const VM on_edge = (u == zero) | (v == zero) | (w == zero);
  const VM inside =
      ((u >= zero) & (v >= zero) & (w >= zero)) | ((u <= zero) & (v <= zero) & (w <= zero));
  const VF det = (u + v) + w;
  const VF inv_det = splat(1.0f) / det;
  const VF t = ((u * z[0] + v * z[1]) + w * z[2]) * (p.wt_s[2] * inv_det);
  const VM ok = andnot(on_edge, inside) & not_equal(det, zero) & (t >= p.tmin) & (t <= p.tmax);
  return {ok, t, v * inv_det, w * inv_det, bits(on_edge) & p.active};
}

template <Kernel K, int Kz>
[[gnu::always_inline]] inline TriangleHits test_triangle(const TriangleBlock& b, int l,
                                                         const Packet& p) {
  if constexpr (K == Kernel::kWatertight) {
    return watertight<Kz>(b, l, p);
  } else {
    return moller_trumbore(b, l, p);
  }
}

// The scalar watertight kernel for lane `lane` against the block's triangle `l`: the exact
// fallback for rays through an edge or a vertex.
inline bool lane_watertight(const Packet& p, int lane, const TriangleBlock& b, int l,
                            TriangleHit& out) {
  const glm::vec3 v0(b.vertex[0][0][l], b.vertex[0][1][l], b.vertex[0][2][l]);
  const glm::vec3 v1(b.vertex[1][0][l], b.vertex[1][1][l], b.vertex[1][2][l]);
  const glm::vec3 v2(b.vertex[2][0][l], b.vertex[2][1][l], b.vertex[2][2][l]);
  return intersect_watertight(p.lane_ray(lane), v0, v1, v2, out);
}

// One ray of the packet against a whole block with the single-ray block kernel.
template <Kernel K>
inline bool lane_block(const Packet& p, int lane, const Ray& ray, const TriangleBlock& b,
                       Hit* best) {
  if constexpr (K == Kernel::kWatertight) {
    return block_watertight(b, p.lane_ray(lane), best);
  } else {
    return block_moller_trumbore(b, ray, best);
  }
}

// Calls fn.template operator()<Kz>() with the packet's shared dominant axis (watertight only), so
// that a leaf's loop over its triangles is compiled once per axis.
template <Kernel K, typename Fn>
[[gnu::always_inline]] inline void with_axis(const Packet& p, Fn&& fn) {
  if constexpr (K == Kernel::kWatertight) {
    switch (p.kz_uniform) {
      case 0:
        return fn.template operator()<0>();
      case 1:
        return fn.template operator()<1>();
      case 2:
        return fn.template operator()<2>();
      default:
        return fn.template operator()<-1>();
    }
  } else {
    fn.template operator()<2>();
  }
}

// The children worth a per-ray box test: those the packet's frustum may hit where the frustum is
// usable, else every child present. The frustum only rejects; hit_box then decides per ray, so a
// small box between the rays of a wide packet is not entered for nothing.
inline uint32_t candidates(const WideNode& node, const Packet& p, float tfar_hi) {
  if (p.frustum.usable) return frustum_hits(node, p, tfar_hi);
  uint32_t present = 0;
  for (int c = 0; c < kWidth; ++c)
    present |= static_cast<uint32_t>(node.child[c] != kEmptyChild) << c;
  return present;
}

// Building the frustum costs a dozen horizontal reductions per packet; it pays only where the tree
// is deep enough that rejecting children saves more, as on big meshes and not on a box of a few
// dozen triangles (docs/PERFORMANCE.md, "Predictions and outcomes").
constexpr size_t kFrustumMinNodes = 16;
inline bool wants_frustum(const WideBvh& tree) {
  return tree.nodes.size() >= kFrustumMinNodes;
}

struct Entry {
  uint32_t ref;
  float t;
  uint32_t lanes;  // the rays that entered it
};

// A leaf reached by at most this many rays of a packet is tested one ray at a time, eight triangles
// per SIMD step, rather than one triangle per step for every lane: on fine meshes a packet spreads
// over many small leaves, each reached by a ray or two (Embree's hybrid traversal does the like).
// A quarter of the lanes: with 16 lanes any threshold from 2 to 4 rays does about equally well
// (docs/PERFORMANCE.md, "Predictions and outcomes").
constexpr int kSingleRayLeafLanes = W / 4;

// Starts loading a child that the packet will visit: a node is 224 bytes and a triangle block 320,
// several cache lines each, and on big scenes traversal waits on memory more than on arithmetic.
inline void prefetch_child(const WideBvh& tree, uint32_t ref) {
  const char* p = (ref & kLeafBit) ? reinterpret_cast<const char*>(&tree.blocks[ref & ~kLeafBit])
                                   : reinterpret_cast<const char*>(&tree.nodes[ref]);
  for (int line = 0; line < 320; line += 64) _mm_prefetch(p + line, _MM_HINT_T0);
}

}  // namespace

// A lane's best-hit prim before any hit: above every triangle index, so ties go to real ones.
constexpr int32_t kNoPrim = std::numeric_limits<int32_t>::max();

// The packet's best hits so far, lane by lane as Hits: t is the lane's current limit (its tmax
// until a hit), prim kNoHit where none was found.
struct LaneHits {
  alignas(64) float t[W], u[W], v[W];
  alignas(64) int32_t prim[W];
  LaneHits(VF best_t, VF best_u, VF best_v, VI best_prim) {
    store(t, best_t);
    store(u, best_u);
    store(v, best_v);
    store(prim, best_prim);
  }
  Hit operator[](size_t l) const {
    return {t[l], u[l], v[l], prim[l] == kNoPrim ? kNoHit : static_cast<uint32_t>(prim[l])};
  }
};

namespace {

template <Kernel K>
void intersect_packet_with(const WideBvh& tree, std::span<const Ray> rays, std::span<Hit> hits) {
  const Packet p = load_packet<K>(rays, wants_frustum(tree));
  // Each lane's best hit so far; (t, prim) ordered lexicographically as in brute force. Starting
  // at tmax makes the box test's far limit simply best_t.
  VF best_t = p.tmax, best_u = splat(0.0f), best_v = splat(0.0f);
  VI best_prim = splat_i(kNoPrim);
  auto set_lane = [&](int l, const Hit& h) [[gnu::always_inline]] {
    const VM lane = single_lane(l);
    best_t = select(lane, splat(h.t), best_t);
    best_u = select(lane, splat(h.u), best_u);
    best_v = select(lane, splat(h.v), best_v);
    best_prim = select(lane, splat_i(static_cast<int32_t>(h.prim)), best_prim);
  };

  if (!tree.nodes.empty() && p.active) {
    Entry stack[kStackSize];
    int sp = 0;
    uint32_t ref = 0, lanes = p.active;
    float farthest_best = hmax(best_t);
    for (;;) {
      if (ref & kLeafBit) {
        const TriangleBlock& b = tree.blocks[ref & ~kLeafBit];
        if (std::popcount(lanes) <= kSingleRayLeafLanes) {
          // Lanes that did not enter the leaf's box cannot hit its triangles (their closest hit
          // has only come nearer since), so only the entering rays are tested.
          const LaneHits current(best_t, best_u, best_v, best_prim);
          for (uint32_t m = lanes; m; m &= m - 1) {
            const int l = std::countr_zero(m);
            const Hit before = current[static_cast<size_t>(l)];
            Hit h = before;
            lane_block<K>(p, l, rays[static_cast<size_t>(l)], b, &h);
            if (h.prim == before.prim && h.t == before.t) continue;
            set_lane(l, h);
          }
          farthest_best = hmax(best_t);
          goto pop;
        }
        with_axis<K>(p, [&]<int Kz>() [[gnu::always_inline]] {
          for (int l = 0; l < kWidth; ++l) {
            if (b.prim[l] == kNoHit) continue;
            const TriangleHits h = test_triangle<K, Kz>(b, l, p);
            if (h.exact) [[unlikely]] {
              // Lanes through an edge or vertex of this triangle: the scalar kernel decides.
              const LaneHits current(best_t, best_u, best_v, best_prim);
              for (uint32_t m = h.exact; m; m &= m - 1) {
                const int lane = std::countr_zero(m);
                TriangleHit th;
                if (!lane_watertight(p, lane, b, l, th)) continue;
                Hit best = current[static_cast<size_t>(lane)];
                offer(best, th.t, th.u, th.v, b.prim[l]);
                if (best.prim == b.prim[l]) set_lane(lane, best);
              }
            }
            if (!bits(h.ok)) continue;
            const VI prim = splat_i(static_cast<int32_t>(b.prim[l]));
            const VM closer = (h.t < best_t) | ((h.t == best_t) & (best_prim > prim));
            const VM take = h.ok & closer;
            best_t = select(take, h.t, best_t);
            best_u = select(take, h.u, best_u);
            best_v = select(take, h.v, best_v);
            best_prim = select(take, prim, best_prim);
          }
        });
        farthest_best = hmax(best_t);
      } else {
        const WideNode& node = tree.nodes[ref];
        Entry near[kWidth];
        int n = 0;
        auto insert = [&](Entry e) {  // sorted farthest first
          int j = n++;
          for (; j > 0 && near[j - 1].t < e.t; --j) near[j] = near[j - 1];
          near[j] = e;
        };
        for (uint32_t m = candidates(node, p, farthest_best); m; m &= m - 1) {
          const int c = std::countr_zero(m);
          VF tn;
          const VM hit = hit_box(node, c, p, best_t, tn);
          if (!bits(hit)) continue;
          prefetch_child(tree, node.child[c]);
          insert({node.child[c], hmin(select(hit, tn, splat(kInf))), bits(hit)});
        }
        if (n > 0) {
          assert(sp + n - 1 <= kStackSize);  // the builder bounds the depth (wide_bvh.h)
          for (int i = 0; i < n - 1; ++i) stack[sp++] = near[i];
          ref = near[n - 1].ref;
          lanes = near[n - 1].lanes;
          continue;
        }
      }
    pop:
      // Pop, skipping subtrees that start beyond every ray's closest hit (ties are kept).
      do {
        if (sp == 0) goto done;
        --sp;
      } while (stack[sp].t > farthest_best);
      ref = stack[sp].ref;
      lanes = stack[sp].lanes;
    }
  }
done:
  const LaneHits best(best_t, best_u, best_v, best_prim);
  for (size_t l = 0; l < rays.size(); ++l) hits[l] = best[l].found() ? best[l] : Hit{};
}

template <Kernel K, bool kCounted = false>
void occluded_packet_with(const WideBvh& tree, std::span<const Ray> rays,
                          std::span<uint8_t> occluded,
                          [[maybe_unused]] PacketSteps* steps = nullptr) {
  Packet p = load_packet<K>(rays, wants_frustum(tree));
  uint32_t blocked = 0;
  float farthest_tmax = hmax(p.tmax);  // over the rays not yet blocked
  // Blocked rays are done: an empty interval takes them out of every later test.
  auto block = [&](VM lanes) [[gnu::always_inline]] {
    blocked |= bits(lanes);
    p.tmax = select(lanes, splat(-kInf), p.tmax);
  };
  if (!tree.nodes.empty() && p.active) {
    uint32_t stack[kStackSize], stack_lanes[kStackSize];
    int sp = 0;
    uint32_t ref = 0, lanes = p.active;
    for (;;) {
      if (ref & kLeafBit) {
        const TriangleBlock& b = tree.blocks[ref & ~kLeafBit];
        const uint32_t open = lanes & ~blocked;
        if (std::popcount(open) <= kSingleRayLeafLanes) {
          if constexpr (kCounted) steps->lane_blocks += static_cast<uint64_t>(std::popcount(open));
          for (uint32_t m = open; m; m &= m - 1) {
            const int l = std::countr_zero(m);
            if (lane_block<K>(p, l, rays[static_cast<size_t>(l)], b, nullptr)) {
              block(single_lane(l));
            }
          }
        } else {
          with_axis<K>(p, [&]<int Kz>() [[gnu::always_inline]] {
            for (int l = 0; l < kWidth; ++l) {
              if (b.prim[l] == kNoHit) continue;
              if constexpr (kCounted) ++steps->packet_triangles;
              const TriangleHits h = test_triangle<K, Kz>(b, l, p);
              if (h.exact) [[unlikely]] {
                for (uint32_t m = h.exact & ~blocked; m; m &= m - 1) {
                  const int lane = std::countr_zero(m);
                  TriangleHit th;
                  if (lane_watertight(p, lane, b, l, th)) block(single_lane(lane));
                }
              }
              if (bits(h.ok)) block(h.ok);
            }
          });
        }
        if ((blocked & p.active) == p.active) break;
        farthest_tmax = hmax(p.tmax);
      } else {
        const WideNode& node = tree.nodes[ref];
        for (uint32_t m = candidates(node, p, farthest_tmax); m; m &= m - 1) {
          const int c = std::countr_zero(m);
          VF tn;
          if constexpr (kCounted) ++steps->box_tests;
          const uint32_t hit = bits(hit_box(node, c, p, p.tmax, tn));
          if (hit) {
            prefetch_child(tree, node.child[c]);
            assert(sp < kStackSize);  // the builder bounds the depth (wide_bvh.h)
            stack_lanes[sp] = hit;
            stack[sp++] = node.child[c];
          }
        }
      }
      if (sp == 0) break;
      --sp;
      ref = stack[sp];
      lanes = stack_lanes[sp];
    }
  }
  for (size_t l = 0; l < rays.size(); ++l) occluded[l] = (blocked >> l) & 1u;
}

}  // namespace

void intersect_packet(const WideBvh& tree, Kernel kernel, std::span<const Ray> rays,
                      std::span<Hit> hits) {
  if (kernel == Kernel::kWatertight) {
    intersect_packet_with<Kernel::kWatertight>(tree, rays, hits);
  } else {
    intersect_packet_with<Kernel::kMollerTrumbore>(tree, rays, hits);
  }
}

void occluded_packet(const WideBvh& tree, Kernel kernel, std::span<const Ray> rays,
                     std::span<uint8_t> occluded) {
  if (kernel == Kernel::kWatertight) {
    occluded_packet_with<Kernel::kWatertight>(tree, rays, occluded);
  } else {
    occluded_packet_with<Kernel::kMollerTrumbore>(tree, rays, occluded);
  }
}

void occluded_packet_counted(const WideBvh& tree, Kernel kernel, std::span<const Ray> rays,
                             std::span<uint8_t> occluded, PacketSteps* steps) {
  if (kernel == Kernel::kWatertight) {
    occluded_packet_with<Kernel::kWatertight, true>(tree, rays, occluded, steps);
  } else {
    occluded_packet_with<Kernel::kMollerTrumbore, true>(tree, rays, occluded, steps);
  }
}

}  // namespace tritrace::bvh

#if defined(__clang__)
#pragma clang diagnostic pop
#endif

#endif  // __AVX2__
