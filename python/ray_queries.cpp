// The chunked, parallel ray loop behind Accel.intersect and Accel.occluded: rays are gathered from
// the caller's arrays into a stack batch (the Ray layout the accels take), checked, traced, and
// their hits scattered to the output arrays, kMaxBatch rays at a time.
#include "ray_queries.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>

#include "flags/flag_values.h"
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

// Ray i as the accels take it, or false when it cannot be traced.
bool load_ray(const RayArrays& in, size_t i, Ray& ray) {
  const float* o = in.origins + i * in.origin_stride;
  const float* d = in.directions + i * in.direction_stride;
  const float tmin = in.tmin[i * in.tmin_stride];
  const float tmax = in.tmax[i * in.tmax_stride];
  ray.origin = glm::vec3(o[0], o[1], o[2]);
  ray.dir = glm::vec3(d[0], d[1], d[2]);
  ray.tmin = tmin;
  // A kernel can produce t = +inf from a tiny determinant; the accels' own largest tmax rejects it.
  ray.tmax = tmax < kRayTMax ? tmax : kRayTMax;
  const bool nonzero = d[0] != 0.0f || d[1] != 0.0f || d[2] != 0.0f;
  return finite3(o) && finite3(d) && nonzero && tmin >= 0.0f && !std::isnan(tmax);
}

std::string format_vec3(const float* p) {
  return "(" + cli::format_float(p[0]) + ", " + cli::format_float(p[1]) + ", " +
         cli::format_float(p[2]) + ")";
}

// Why ray i cannot be traced; called only for a ray that load_ray refused.
RayProblem describe_problem(const RayArrays& in, size_t i) {
  const float* o = in.origins + i * in.origin_stride;
  const float* d = in.directions + i * in.direction_stride;
  const float tmin = in.tmin[i * in.tmin_stride];
  const std::string ray = "ray " + std::to_string(i);
  if (!finite3(o)) return {i, "origins: " + ray + " is not finite: " + format_vec3(o)};
  if (!finite3(d)) return {i, "directions: " + ray + " is not finite: " + format_vec3(d)};
  if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) return {i, "directions: " + ray + " is zero"};
  if (!(tmin >= 0.0f)) {
    return {i, "tmin: " + ray + " must be a number >= 0, got " + cli::format_float(tmin)};
  }
  return {i, "tmax: " + ray + " is NaN"};
}

std::optional<RayProblem> first_problem(const RayArrays& in) {
  Ray ray;
  for (size_t i = 0; i < in.count; ++i) {
    if (!load_ray(in, i, ray)) return describe_problem(in, i);
  }
  return std::nullopt;
}

int octant(const glm::vec3& d) {
  return (std::signbit(d.x) ? 1 : 0) | (std::signbit(d.y) ? 2 : 0) | (std::signbit(d.z) ? 4 : 0);
}

// Whether a batch goes to the accel's packet path: at least half of its packets hold rays of one
// direction octant, as a camera's or a lidar's consecutive rays do and random rays (one packet in
// 8^(kPacket-1)) do not.
bool looks_coherent(std::span<const Ray> rays) {
  size_t packets = 0, shared = 0;
  for (size_t first = 0; first + kPacket <= rays.size(); first += kPacket) {
    const int o = octant(rays[first].dir);
    bool same = true;
    for (size_t k = 1; k < kPacket; ++k) same = same && octant(rays[first + k].dir) == o;
    ++packets;
    shared += same ? 1 : 0;
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
    std::array<Ray, kChunk> batch;
    const size_t n = end - begin;
    bool ok = true;
    for (size_t i = 0; i < n; ++i) ok &= load_ray(in, begin + i, batch[i]);
    if (!ok) {
      failed.store(true, std::memory_order_relaxed);
      return;
    }
    fn(std::span<const Ray>(batch.data(), n), begin);
  });
  if (failed.load()) return first_problem(in);
  return std::nullopt;
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

std::optional<RayProblem> trace_closest(const Accel& accel, const RayArrays& rays,
                                        const HitArrays& out, Coherence coherence,
                                        std::span<const uint32_t> triangle_ids, bool swap_uv) {
  return for_each_batch(rays, [&](std::span<const Ray> batch, size_t first) {
    std::array<Hit, kChunk> hits;
    const std::span<Hit> h(hits.data(), batch.size());
    if (use_packets(coherence, batch)) {
      accel.intersect(batch, h);
    } else {
      accel.intersect_incoherent(batch, h);
    }
    constexpr float kInf = std::numeric_limits<float>::infinity();
    for (size_t i = 0; i < batch.size(); ++i) {
      const Hit& hit = hits[i];
      const bool found = hit.found();
      const uint32_t id = !found ? 0u : triangle_ids.empty() ? hit.prim : triangle_ids[hit.prim];
      out.t[first + i] = found ? hit.t : kInf;
      out.prim[first + i] = found ? static_cast<int32_t>(id) : -1;
      const float u = swap_uv ? hit.v : hit.u, v = swap_uv ? hit.u : hit.v;
      out.u[first + i] = found ? u : 0.0f;
      out.v[first + i] = found ? v : 0.0f;
    }
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
