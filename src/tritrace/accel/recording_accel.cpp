#include "tritrace/accel/recording_accel.h"

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstring>
#include <optional>

#include "tritrace/parallel.h"

namespace tritrace {
namespace {

void append(RayBatches& to, std::span<const Ray> rays) {
  to.rays.insert(to.rays.end(), rays.begin(), rays.end());
  to.sizes.push_back(static_cast<uint32_t>(rays.size()));
}

// One recorded batch: its rays and answers in a thread's buffer.
template <typename Answer>
struct BatchRef {
  const Ray* rays;
  const Answer* answers;
  uint32_t size;
};

template <typename Answer>
void collect(const RayBatches& from, const std::vector<Answer>& answers,
             std::vector<BatchRef<Answer>>& out) {
  size_t offset = 0;
  for (const uint32_t size : from.sizes) {
    out.push_back({from.rays.data() + offset, answers.data() + offset, size});
    offset += size;
  }
}

// The batches in an order that depends only on their contents.
template <typename Answer>
void merge_sorted(std::vector<BatchRef<Answer>>& refs, RayBatches& to,
                  std::vector<Answer>& answers) {
  std::sort(refs.begin(), refs.end(), [](const BatchRef<Answer>& a, const BatchRef<Answer>& b) {
    if (a.size != b.size) return a.size < b.size;
    return std::memcmp(a.rays, b.rays, a.size * sizeof(Ray)) < 0;
  });
  size_t total = 0;
  for (const BatchRef<Answer>& r : refs) total += r.size;
  to.rays.reserve(total);
  answers.reserve(total);
  to.sizes.reserve(refs.size());
  for (const BatchRef<Answer>& r : refs) {
    append(to, std::span<const Ray>(r.rays, r.size));
    answers.insert(answers.end(), r.answers, r.answers + r.size);
  }
}

// Calls trace(rays, first) for every batch on `threads` threads, each taking the next batch in
// order, inside an arena of that many threads (the renderer's set-up).
template <typename Trace>
void for_each_batch(const RayBatches& batches, int threads, const Trace& trace) {
  std::vector<size_t> offsets(batches.sizes.size() + 1, 0);
  for (size_t k = 0; k < batches.sizes.size(); ++k) offsets[k + 1] = offsets[k] + batches.sizes[k];
  std::atomic<size_t> next{0};
  const auto run = [&] {
    for (size_t k = next.fetch_add(1, std::memory_order_relaxed); k < batches.sizes.size();
         k = next.fetch_add(1, std::memory_order_relaxed)) {
      trace(std::span<const Ray>(batches.rays.data() + offsets[k], batches.sizes[k]), offsets[k]);
    }
  };
  threads = std::max(1, threads);
  std::optional<tbb::global_control> allow_threads;
  if (static_cast<size_t>(threads) >
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)) {
    allow_threads.emplace(tbb::global_control::max_allowed_parallelism,
                          static_cast<size_t>(threads));
  }
  tbb::task_arena arena(threads);
  arena.execute([&] {
    parallel::TaskGroup group;
    for (int t = 1; t < threads; ++t) group.run(run);
    run();
    group.wait();
  });
}

}  // namespace

RecordingAccel::Buffer& RecordingAccel::buffer() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::unique_ptr<Buffer>& b = buffers_[std::this_thread::get_id()];
  if (!b) b = std::make_unique<Buffer>();
  return *b;
}

void RecordingAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  inner_.intersect(rays, hits);
  coherent_rays_.fetch_add(rays.size(), std::memory_order_relaxed);
}

void RecordingAccel::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  inner_.occluded(rays, occluded);
  coherent_rays_.fetch_add(rays.size(), std::memory_order_relaxed);
}

void RecordingAccel::intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const {
  inner_.intersect_incoherent(rays, hits);
  RecordedRays& r = buffer().recorded;
  append(r.closest, rays);
  r.hits.insert(r.hits.end(), hits.begin(), hits.begin() + static_cast<ptrdiff_t>(rays.size()));
}

void RecordingAccel::occluded_incoherent(std::span<const Ray> rays,
                                         std::span<uint8_t> occluded) const {
  inner_.occluded_incoherent(rays, occluded);
  RecordedRays& r = buffer().recorded;
  append(r.any, rays);
  r.occluded.insert(r.occluded.end(), occluded.begin(),
                    occluded.begin() + static_cast<ptrdiff_t>(rays.size()));
}

RecordedRays RecordingAccel::take() {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<BatchRef<Hit>> closest;
  std::vector<BatchRef<uint8_t>> any;
  for (const auto& [id, b] : buffers_) {
    collect(b->recorded.closest, b->recorded.hits, closest);
    collect(b->recorded.any, b->recorded.occluded, any);
  }
  RecordedRays out;
  merge_sorted(closest, out.closest, out.hits);
  merge_sorted(any, out.any, out.occluded);
  out.coherent_rays = coherent_rays_.exchange(0);
  buffers_.clear();
  return out;
}

void replay_closest(const Accel& accel, const RayBatches& batches, std::span<Hit> hits,
                    int threads) {
  for_each_batch(batches, threads, [&](std::span<const Ray> rays, size_t first) {
    accel.intersect_incoherent(rays, hits.subspan(first, rays.size()));
  });
}

void replay_any(const Accel& accel, const RayBatches& batches, std::span<uint8_t> occluded,
                int threads) {
  for_each_batch(batches, threads, [&](std::span<const Ray> rays, size_t first) {
    accel.occluded_incoherent(rays, occluded.subspan(first, rays.size()));
  });
}

}  // namespace tritrace
