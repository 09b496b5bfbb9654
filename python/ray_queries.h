// Ray queries on caller-owned arrays for the Python module: origins, directions and ray intervals
// read in place (structure of arrays, or one value broadcast to every ray), traced through an
// Accel's batch queries in chunks over all cores, results written straight into the output arrays.
// No Python here, so the work runs with the GIL released.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "tritrace/accel/accel.h"

namespace tritrace::python {

// Where ray i's values are: origin at origins + i * origin_stride (3 floats; stride 0 broadcasts
// one origin to every ray), the same for directions, tmin and tmax (one float each).
struct RayArrays {
  size_t count = 0;
  const float* origins = nullptr;
  size_t origin_stride = 3;
  const float* directions = nullptr;
  size_t direction_stride = 3;
  const float* tmin = nullptr;
  size_t tmin_stride = 0;
  const float* tmax = nullptr;
  size_t tmax_stride = 0;
};

// How a chunk of rays reaches the accel: through its batch queries (packets where it has them,
// for rays that share an origin and direction octant, such as a camera's), its incoherent ones
// (one ray at a time), or either, chosen per chunk by how many of its packets share a direction
// octant. The hits are the same bit for bit; only the speed differs.
enum class Coherence { kAuto, kCoherent, kIncoherent };

// The closest hit of each ray: t (+inf on a miss), the triangle (-1 on a miss, else
// `triangle_ids[prim]` when triangle_ids is not empty, else prim) and the barycentrics u, v (0 on
// a miss; each other's when swap_uv is set).
struct HitArrays {
  float* t = nullptr;
  int32_t* prim = nullptr;
  float* u = nullptr;
  float* v = nullptr;
  // Write with non-temporal stores (the four arrays 16-byte aligned): for results larger than the
  // caches, which then need not read every line before filling it.
  bool stream = false;
};

// The first ray that cannot be traced and why, in the words of an error message: an origin or
// direction that is not finite, a zero direction, a negative or NaN tmin, a NaN tmax.
struct RayProblem {
  size_t index = 0;
  std::string reason;
};

// Checks every ray, then traces them over all cores of the current TBB arena. Returns the first
// problem (the lowest index) and leaves the outputs unspecified when there is one.
std::optional<RayProblem> trace_closest(const Accel& accel, const RayArrays& rays,
                                        const HitArrays& out, Coherence coherence,
                                        std::span<const uint32_t> triangle_ids, bool swap_uv);
// out[i] = 1 where ray i hits any triangle within its interval, else 0 (NumPy's bool layout).
std::optional<RayProblem> trace_occluded(const Accel& accel, const RayArrays& rays, uint8_t* out,
                                         Coherence coherence);

// Rays are handed out in chunks of this many (the renderer's batch size, kMaxBatch): batch k of
// for_each_ray_batch starts at ray k * kRayChunk.
inline constexpr size_t kRayChunk = 256;

// fn(batch, first) for consecutive batches of at most kRayChunk rays, first the index of the
// batch's first ray, on every core of the current TBB arena: the rays loaded and checked as the
// queries above load them. Returns the first problem (the lowest index) when a ray cannot be
// traced; fn may then have run for some batches.
std::optional<RayProblem> for_each_ray_batch(
    const RayArrays& rays, const std::function<void(std::span<const Ray> batch, size_t first)>& fn);

// body(begin, end) over [0, count) in consecutive chunks of at most `chunk` items, handed to every
// thread of the current TBB arena from a shared counter (as the renderer hands out tiles); on the
// calling thread alone when there is a single chunk.
void parallel_chunks(size_t count, size_t chunk,
                     const std::function<void(size_t begin, size_t end)>& body);

}  // namespace tritrace::python
