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
// 0..k-1. Batches come in groups, each the work one thread did between two coherent queries (in a
// path tracer: the bounces and shadow rays of one tile's camera rays), in the order that thread
// made them: group g is batches [groups[g], groups[g + 1]) (the last one up to the end).
struct RayBatches {
  std::vector<Ray> rays;
  // One per ray: the triangle it leaves, as given to the *_incoherent_from queries (kNoHit where
  // none was given), which the replays pass on.
  std::vector<uint32_t> origins;
  std::vector<uint32_t> sizes;
  std::vector<uint32_t> groups;
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

// How take() orders the groups: kSorted, by the coherent query that started each (the same on
// any number of threads); kCallOrder, in the order they were recorded, which needs every query
// made on one thread (a render on one thread, which takes its tiles in order).
enum class GroupOrder { kSorted, kCallOrder };

class RecordingAccel final : public Accel {
 public:
  // `inner` must outlive this.
  explicit RecordingAccel(const Accel& inner, GroupOrder order = GroupOrder::kSorted)
      : inner_(inner), order_(order) {}

  using Accel::intersect;
  using Accel::occluded;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;
  void intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;
  void intersect_incoherent_from(std::span<const Ray> rays, std::span<const uint32_t> origins,
                                 std::span<Hit> hits) const override;
  void occluded_incoherent_from(std::span<const Ray> rays, std::span<const uint32_t> origins,
                                std::span<uint8_t> occluded) const override;

  // Everything recorded since the last take(), and forgets it. Each thread records into its own
  // buffers in call order, and starts a group at each coherent query (a tile's camera rays): the
  // incoherent batches until the next one belong to it, in call order, so that a replay keeps the
  // locality the renderer's tiles give (a tile's bounces follow one another through the same part
  // of the tree). With GroupOrder::kSorted the groups of all threads are put in an order that does
  // not depend on which thread traced which: by the coherent query that started them (its size,
  // its first ray's bytes, a hash of all its rays), then by their first batches' rays, so that a
  // deterministic render records the same RecordedRays on any number of threads. With kCallOrder
  // they stay in the one recording thread's order (std::logic_error if several threads recorded).
  // The order matters to a replay's speed: on terrain:1m, Embree's single rays took 5-10% longer
  // with sorted groups than in the tiles' order, and 20-35% longer with every batch sorted on its
  // own (tritrace's: 0-5%; docs/PERFORMANCE.md). Not while queries are running.
  RecordedRays take();

 private:
  // The coherent query that started a group, and where its batches begin in the buffer.
  struct Group {
    uint32_t key_size = 0;  // 0: incoherent queries before any coherent one
    Ray key_first{};
    uint64_t key_hash = 0;
    uint32_t closest_begin = 0, any_begin = 0;  // batch indices in the buffer
  };
  struct Buffer {
    RecordedRays recorded;
    std::vector<Group> groups;
  };
  // Starts a group in the calling thread's buffer for a coherent query of `rays`.
  void start_group(std::span<const Ray> rays) const;
  Buffer& buffer() const;  // the calling thread's

  const Accel& inner_;
  GroupOrder order_;
  mutable std::mutex mutex_;
  mutable std::unordered_map<std::thread::id, std::unique_ptr<Buffer>> buffers_;
  mutable std::atomic<uint64_t> coherent_rays_{0};
};

// Traces every batch of `batches` through accel.intersect_incoherent_from (closest) or
// accel.occluded_incoherent_from (any) with the recorded origins, one call per batch as recorded,
// on `threads` threads that take the groups in order, as the renderer's threads take tiles, each
// group's batches in order. `hits` / `occluded` hold one answer per ray.
void replay_closest(const Accel& accel, const RayBatches& batches, std::span<Hit> hits,
                    int threads);
void replay_any(const Accel& accel, const RayBatches& batches, std::span<uint8_t> occluded,
                int threads);

}  // namespace tritrace
