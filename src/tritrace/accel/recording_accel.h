// RecordingAccel: an Accel that forwards every query to the one it wraps and keeps the rays and
// answers of the incoherent queries (a path tracer's bounce and shadow rays), batch by batch, so
// that a benchmark can trace exactly those rays again through other accels (`tritrace bench
// --secondary-rays`). Not for rendering: every incoherent call copies its rays.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <unordered_map>
#include <vector>

#include "tritrace/accel/accel.h"

namespace tritrace {

// Rays in the batches they were traced in: batch k is the sizes[k] rays after those of batches
// 0..k-1.
struct RayBatches {
  std::vector<Ray> rays;
  std::vector<uint32_t> sizes;
};

// What a RecordingAccel saw: the closest-hit queries (intersect_incoherent) with the hits the
// wrapped accel gave, the any-hit queries (occluded_incoherent) with its answers, and how many
// rays went through the coherent queries (intersect, occluded), which are forwarded only.
struct RecordedRays {
  RayBatches closest;
  std::vector<Hit> hits;  // one per ray of `closest`
  RayBatches any;
  std::vector<uint8_t> occluded;  // one per ray of `any`
  uint64_t coherent_rays = 0;
};

class RecordingAccel final : public Accel {
 public:
  // `inner` must outlive this.
  explicit RecordingAccel(const Accel& inner) : inner_(inner) {}

  using Accel::intersect;
  using Accel::occluded;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;
  void intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;

  // Everything recorded since the last take(), and forgets it. Each thread records into its own
  // buffers in call order; the batches of all threads are then put in one order that does not
  // depend on which thread traced which batch: sorted by their rays' bytes (size first). A
  // deterministic render therefore records the same RecordedRays on any number of threads.
  // Not while queries are running.
  RecordedRays take();

 private:
  struct Buffer {
    RecordedRays recorded;
  };
  Buffer& buffer() const;  // the calling thread's

  const Accel& inner_;
  mutable std::mutex mutex_;
  mutable std::unordered_map<std::thread::id, std::unique_ptr<Buffer>> buffers_;
  mutable std::atomic<uint64_t> coherent_rays_{0};
};

// Traces every batch of `batches` through accel.intersect_incoherent (closest) or
// accel.occluded_incoherent (any), one call per batch as recorded, on `threads` threads that take
// the batches in order, as the renderer's threads take tiles. `hits` / `occluded` hold one answer
// per ray.
void replay_closest(const Accel& accel, const RayBatches& batches, std::span<Hit> hits,
                    int threads);
void replay_any(const Accel& accel, const RayBatches& batches, std::span<uint8_t> occluded,
                int threads);

}  // namespace tritrace
