// The chunked, parallel ray loop behind Accel.intersect and Accel.occluded: rays are gathered from
// the caller's arrays into a stack batch (the Ray layout the accels take), checked, traced, and
// their hits scattered to the output arrays, kMaxBatch rays at a time.
#include "ray_queries.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <limits>

#if defined(__SSE4_1__)
#include <immintrin.h>
#endif

#include "tritrace/job/setting_values.h"
#include "tritrace/math/simd_lanes.h"
#include "tritrace/parallel.h"
#include "tritrace/render/integrator.h"

namespace tritrace::python {
namespace {

// The renderer's batch size: one virtual call per 256 rays, and a stack batch of 8 KiB.
constexpr size_t kChunk = kMaxBatch;
// Rays that share a packet in the BVH's and Embree's packet traversals.
constexpr size_t kPacket = simd::kLanes > 0 ? simd::kLanes : 8;

bool finite3(const float* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

// 1 when x is neither infinite nor NaN, from its exponent bits: no branch, so loops vectorise.
inline unsigned finite_bit(float x) {
  return (std::bit_cast<uint32_t>(x) & 0x7f800000u) != 0x7f800000u;
}

// 1 where any of the n floats at p is infinite or NaN: a contiguous loop that vectorises.
inline unsigned any_non_finite(const float* p, size_t n) {
  unsigned bad = 0;
  for (size_t j = 0; j < n; ++j) bad |= finite_bit(p[j]) ^ 1u;
  return bad;
}

// 1 where any of the n directions at d (3 floats each) is zero (either sign).
inline unsigned any_zero(const float* d, size_t n) {
  unsigned bad = 0;
  for (size_t i = 0; i < n; ++i) {
    const uint32_t bits = std::bit_cast<uint32_t>(d[3 * i]) |
                          std::bit_cast<uint32_t>(d[3 * i + 1]) |
                          std::bit_cast<uint32_t>(d[3 * i + 2]);
    bad |= (bits & 0x7fffffffu) == 0 ? 1u : 0u;
  }
  return bad;
}

// Rays [first, first + n) as the accels take them, into batch; false when one cannot be traced
// (then describe_problem says why). This runs for every ray, and on a small scene a ray costs only
// some 50 cycles to trace, so the common layouts (origins and directions each per ray or shared,
// one tmin and tmax for all) get loops with constant strides that the compiler vectorises, and
// the checks run over the arrays as they are, contiguous.
template <size_t kOriginStride, size_t kDirectionStride>
bool load_batch_fast(const RayArrays& in, size_t first, size_t n, Ray* batch) {
  const float* o = in.origins + first * kOriginStride;
  const float* d = in.directions + first * kDirectionStride;
  const float tmin = *in.tmin;
  const float tmax = std::min(*in.tmax, kRayTMax);  // NaN stays NaN
  // The shared origin or direction, and the interval, are checked once.
  unsigned bad = static_cast<unsigned>(!(tmin >= 0.0f)) | static_cast<unsigned>(tmax != tmax);
  if (kOriginStride == 0) bad |= any_non_finite(o, 3);
  if (kDirectionStride == 0) bad |= any_non_finite(d, 3) | any_zero(d, 1);
  size_t i = 0;
#if defined(__SSE4_1__)
  static_assert(sizeof(Ray) == 32, "a Ray is (origin, dir.x) then (dir.y, dir.z, tmin, tmax)");
  // Two 16-byte stores per ray, and the checks on the same registers. An unaligned load of a
  // per-ray vector reads the next ray's first float too (checked with this ray: a false alarm
  // only where the next ray is bad itself), so the last ray, whose next float may lie past the
  // array, is left to the loop below.
  const __m128 interval = _mm_setr_ps(tmin, tmax, tmin, tmax);
  const __m128 one_origin = _mm_setr_ps(o[0], o[1], o[2], 0.0f);
  const __m128 one_direction = _mm_setr_ps(d[0], d[1], d[2], 1.0f);
  const __m128i exponent = _mm_set1_epi32(0x7f800000);
  const __m128i magnitude3 = _mm_setr_epi32(0x7fffffff, 0x7fffffff, 0x7fffffff, 0);
  __m128i non_finite = _mm_setzero_si128();
  int zero = 0;
  for (; i + 1 < n; ++i) {
    const __m128 oi = kOriginStride == 0 ? one_origin : _mm_loadu_ps(o + 3 * i);
    const __m128 di = kDirectionStride == 0 ? one_direction : _mm_loadu_ps(d + 3 * i);
    float* out = reinterpret_cast<float*>(batch + i);
    _mm_storeu_ps(out, _mm_insert_ps(oi, di, 0x30));  // (ox, oy, oz, dx)
    _mm_storeu_ps(out + 4, _mm_shuffle_ps(di, interval, _MM_SHUFFLE(1, 0, 2, 1)));
    if constexpr (kOriginStride != 0) {
      const __m128i e = _mm_and_si128(_mm_castps_si128(oi), exponent);
      non_finite = _mm_or_si128(non_finite, _mm_cmpeq_epi32(e, exponent));
    }
    if constexpr (kDirectionStride != 0) {
      const __m128i bits = _mm_castps_si128(di);
      non_finite =
          _mm_or_si128(non_finite, _mm_cmpeq_epi32(_mm_and_si128(bits, exponent), exponent));
      zero |= _mm_testz_si128(bits, magnitude3);
    }
  }
  bad |=
      static_cast<unsigned>(!_mm_testz_si128(non_finite, non_finite)) | static_cast<unsigned>(zero);
#endif
  for (; i < n; ++i) {
    const float* oi = o + i * kOriginStride;
    const float* di = d + i * kDirectionStride;
    batch[i].origin = glm::vec3(oi[0], oi[1], oi[2]);
    batch[i].dir = glm::vec3(di[0], di[1], di[2]);
    batch[i].tmin = tmin;
    batch[i].tmax = tmax;
    if constexpr (kOriginStride != 0) bad |= any_non_finite(oi, 3);
    if constexpr (kDirectionStride != 0) bad |= any_non_finite(di, 3) | any_zero(di, 1);
  }
  return bad == 0;
}

// Any layout, one ray at a time.
bool load_batch_general(const RayArrays& in, size_t first, size_t n, Ray* batch) {
  unsigned bad = 0;
  for (size_t i = 0; i < n; ++i) {
    const size_t k = first + i;
    const float* o = in.origins + k * in.origin_stride;
    const float* d = in.directions + k * in.direction_stride;
    const float tmin = in.tmin[k * in.tmin_stride];
    const float tmax = std::min(in.tmax[k * in.tmax_stride], kRayTMax);
    Ray& ray = batch[i];
    ray.origin = glm::vec3(o[0], o[1], o[2]);
    ray.dir = glm::vec3(d[0], d[1], d[2]);
    ray.tmin = tmin;
    ray.tmax = tmax;
    bad |= any_non_finite(o, 3) | any_non_finite(d, 3) | any_zero(d, 1) |
           static_cast<unsigned>(!(tmin >= 0.0f)) | static_cast<unsigned>(tmax != tmax);
  }
  return bad == 0;
}

// A kernel can produce t = +inf from a tiny determinant; the accels' own largest tmax (kRayTMax)
// rejects it, so a larger tmax becomes that.
bool load_batch(const RayArrays& in, size_t first, size_t n, Ray* batch) {
  if (in.tmin_stride == 0 && in.tmax_stride == 0) {
    const bool one_origin = in.origin_stride == 0, one_direction = in.direction_stride == 0;
    if (!one_origin && !one_direction) return load_batch_fast<3, 3>(in, first, n, batch);
    if (one_origin && !one_direction) return load_batch_fast<0, 3>(in, first, n, batch);
    if (!one_origin && one_direction) return load_batch_fast<3, 0>(in, first, n, batch);
  }
  return load_batch_general(in, first, n, batch);
}

std::string point_text(const float* p) {
  std::string text = "(";
  for (int i = 0; i < 3; ++i) {
    if (i > 0) text += ", ";
    text += format_float(p[i]);
  }
  return text + ")";
}

// Why ray i cannot be traced; called only for a ray that load_batch refused.
RayProblem describe_problem(const RayArrays& in, size_t i) {
  const float* o = in.origins + i * in.origin_stride;
  const float* d = in.directions + i * in.direction_stride;
  const float tmin = in.tmin[i * in.tmin_stride];
  const std::string ray = "ray " + std::to_string(i);
  if (!finite3(o)) return {i, "origins: " + ray + " is not finite: " + point_text(o)};
  if (!finite3(d)) return {i, "directions: " + ray + " is not finite: " + point_text(d)};
  if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) return {i, "directions: " + ray + " is zero"};
  if (!(tmin >= 0.0f)) {
    return {i, "tmin: " + ray + " must be a number >= 0, got " + format_float(tmin)};
  }
  return {i, "tmax: " + ray + " is NaN"};
}

std::optional<RayProblem> first_problem(const RayArrays& in) {
  Ray ray;
  for (size_t i = 0; i < in.count; ++i) {
    if (!load_batch(in, i, 1, &ray)) return describe_problem(in, i);
  }
  return std::nullopt;
}

// The signs of a direction's components as three bits.
inline unsigned octant(const glm::vec3& d) {
  return (std::bit_cast<uint32_t>(d.x) >> 31) | (std::bit_cast<uint32_t>(d.y) >> 31) << 1 |
         (std::bit_cast<uint32_t>(d.z) >> 31) << 2;
}

// Whether a batch goes to the accel's packet path: at least half of its packets hold rays of one
// direction octant, as a camera's or a lidar's consecutive rays do and random rays do not.
bool looks_coherent(std::span<const Ray> rays) {
  size_t packets = 0, shared = 0;
  // The first and last ray of each packet stand for it: a quarter of the work of comparing all
  // eight, and random rays still agree in only one packet in eight.
  for (size_t first = 0; first + kPacket <= rays.size(); first += kPacket) {
    ++packets;
    shared += octant(rays[first].dir) == octant(rays[first + kPacket - 1].dir) ? 1 : 0;
  }
  return packets > 0 && 2 * shared >= packets;
}

bool use_packets(Coherence c, std::span<const Ray> rays) {
  return c == Coherence::kCoherent || (c == Coherence::kAuto && looks_coherent(rays));
}

// Runs fn(batch of rays, first index) over every chunk; stops handing out chunks once a ray cannot
// be traced, and then reports the lowest such ray.
template <typename Fn>
std::optional<RayProblem> for_each_batch(const RayArrays& in, Fn&& fn) {
  std::atomic<bool> failed{false};
  parallel_chunks(in.count, kChunk, [&](size_t begin, size_t end) {
    if (failed.load(std::memory_order_relaxed)) return;
    // Per thread and reused, as the renderer's batches are: a fresh array would initialise every
    // ray (Ray has default values) on each batch. No thread works on two batches at once.
    thread_local std::array<Ray, kChunk> batch;
    const size_t n = end - begin;
    if (!load_batch(in, begin, n, batch.data())) {
      failed.store(true, std::memory_order_relaxed);
      return;
    }
    fn(std::span<const Ray>(batch.data(), n), begin);
  });
  if (failed.load()) return first_problem(in);
  return std::nullopt;
}

// Writes hits to the output arrays from index `first`: the caller's triangle index, and the
// barycentrics in the caller's vertex order.
void scatter_hits(std::span<const Hit> hits, size_t first, const HitArrays& out,
                  std::span<const uint32_t> triangle_ids, bool swap_uv) {
  static_assert(kNoHit == 0xffffffffu, "a miss's prim reads as -1 in int32");
  constexpr float kInf = std::numeric_limits<float>::infinity();
  float* t = out.t + first;
  int32_t* prim = out.prim + first;
  float* u = out.u + first;
  float* v = out.v + first;
  size_t i = 0;
#if defined(__SSE4_1__)
  static_assert(sizeof(Hit) == 16 && offsetof(Hit, t) == 0 && offsetof(Hit, u) == 4 &&
                offsetof(Hit, v) == 8 && offsetof(Hit, prim) == 12);
  // Four hits at a time, transposed from (t, u, v, prim) rows into the four arrays.
  const __m128 inf = _mm_set1_ps(kInf);
  for (; i + 4 <= hits.size(); i += 4) {
    const float* h = reinterpret_cast<const float*>(hits.data() + i);
    __m128 r0 = _mm_loadu_ps(h), r1 = _mm_loadu_ps(h + 4), r2 = _mm_loadu_ps(h + 8),
           r3 = _mm_loadu_ps(h + 12);
    _MM_TRANSPOSE4_PS(r0, r1, r2, r3);  // r0: t, r1: u, r2: v, r3: prim
    const __m128 missed =
        _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_castps_si128(r3), _mm_set1_epi32(-1)));
    const __m128 ht = _mm_blendv_ps(r0, inf, missed);
    const __m128 hu = _mm_andnot_ps(missed, swap_uv ? r2 : r1);
    const __m128 hv = _mm_andnot_ps(missed, swap_uv ? r1 : r2);
    if (out.stream) {
      // Large results: written around the cache, without first reading the lines they fill.
      _mm_stream_ps(t + i, ht);
      _mm_stream_si128(reinterpret_cast<__m128i*>(prim + i), _mm_castps_si128(r3));
      _mm_stream_ps(u + i, hu);
      _mm_stream_ps(v + i, hv);
    } else {
      _mm_storeu_ps(t + i, ht);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(prim + i), _mm_castps_si128(r3));
      _mm_storeu_ps(u + i, hu);
      _mm_storeu_ps(v + i, hv);
    }
  }
  if (out.stream) _mm_sfence();  // the streamed stores are seen before the batch counts as done
#endif
  for (; i < hits.size(); ++i) {
    const Hit& h = hits[i];
    const bool found = h.prim != kNoHit;
    t[i] = found ? h.t : kInf;
    prim[i] = found ? static_cast<int32_t>(h.prim) : -1;
    u[i] = found ? (swap_uv ? h.v : h.u) : 0.0f;
    v[i] = found ? (swap_uv ? h.u : h.v) : 0.0f;
  }
  if (!triangle_ids.empty()) {
    for (size_t k = 0; k < hits.size(); ++k) {
      if (prim[k] >= 0) prim[k] = static_cast<int32_t>(triangle_ids[static_cast<size_t>(prim[k])]);
    }
  }
}

}  // namespace

void parallel_chunks(size_t count, size_t chunk,
                     const std::function<void(size_t begin, size_t end)>& body) {
  const size_t chunks = (count + chunk - 1) / chunk;
  if (chunks <= 1) {
    if (count > 0) body(0, count);
    return;
  }
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t c = next.fetch_add(1, std::memory_order_relaxed); c < chunks;
         c = next.fetch_add(1, std::memory_order_relaxed)) {
      body(c * chunk, std::min(count, (c + 1) * chunk));
    }
  };
  const size_t threads =
      std::min(chunks, static_cast<size_t>(std::max(1, tbb::this_task_arena::max_concurrency())));
  parallel::TaskGroup group;
  for (size_t t = 1; t < threads; ++t) group.run(work);
  work();
  group.wait();
}

std::optional<RayProblem> for_each_ray_batch(
    const RayArrays& rays,
    const std::function<void(std::span<const Ray> batch, size_t first)>& fn) {
  static_assert(kChunk == kRayChunk);
  return for_each_batch(rays, fn);
}

std::optional<RayProblem> trace_closest(const Accel& accel, const RayArrays& rays,
                                        const HitArrays& out, Coherence coherence,
                                        std::span<const uint32_t> triangle_ids, bool swap_uv) {
  return for_each_batch(rays, [&](std::span<const Ray> batch, size_t first) {
    thread_local std::array<Hit, kChunk> hits;
    const std::span<Hit> h(hits.data(), batch.size());
    if (use_packets(coherence, batch)) {
      accel.intersect(batch, h);
    } else {
      accel.intersect_incoherent(batch, h);
    }
    scatter_hits(std::span<const Hit>(hits.data(), batch.size()), first, out, triangle_ids,
                 swap_uv);
  });
}

std::optional<RayProblem> trace_occluded(const Accel& accel, const RayArrays& rays, uint8_t* out,
                                         Coherence coherence) {
  return for_each_batch(rays, [&](std::span<const Ray> batch, size_t first) {
    const std::span<uint8_t> o(out + first, batch.size());
    if (use_packets(coherence, batch)) {
      accel.occluded(batch, o);
    } else {
      accel.occluded_incoherent(batch, o);
    }
  });
}

}  // namespace tritrace::python
