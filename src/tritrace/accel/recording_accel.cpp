#include "tritrace/accel/recording_accel.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "tritrace/parallel.h"

namespace tritrace {
namespace {

void append(RayBatches& to, std::span<const Ray> rays, std::span<const uint32_t> origins) {
  to.rays.insert(to.rays.end(), rays.begin(), rays.end());
  if (origins.size() == rays.size()) {
    to.origins.insert(to.origins.end(), origins.begin(), origins.end());
  } else {
    to.origins.insert(to.origins.end(), rays.size(), kNoHit);
  }
  to.sizes.push_back(static_cast<uint32_t>(rays.size()));
}

// Where each batch of `from` starts in its rays: offsets[k], with offsets[size] the end.
std::vector<size_t> batch_offsets(const RayBatches& from) {
  std::vector<size_t> offsets(from.sizes.size() + 1, 0);
  for (size_t k = 0; k < from.sizes.size(); ++k) offsets[k + 1] = offsets[k] + from.sizes[k];
  return offsets;
}

uint64_t fnv1a(std::span<const Ray> rays) {
  uint64_t h = 1469598103934665603ull;
  const auto* p = reinterpret_cast<const unsigned char*>(rays.data());
  for (size_t i = 0; i < rays.size_bytes(); ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

// Batches [begin, end) of one kind in one thread's buffer.
struct Range {
  const RayBatches* from;
  const std::vector<size_t>* offsets;
  uint32_t begin, end;
};

// -1, 0, 1 as range a's first batch orders before, with or after b's (size, then rays' bytes).
int compare_first(const Range& a, const Range& b) {
  const bool ea = a.begin == a.end, eb = b.begin == b.end;
  if (ea || eb) return ea == eb ? 0 : (ea ? -1 : 1);
  const uint32_t na = a.from->sizes[a.begin], nb = b.from->sizes[b.begin];
  if (na != nb) return na < nb ? -1 : 1;
  return std::memcmp(a.from->rays.data() + (*a.offsets)[a.begin],
                     b.from->rays.data() + (*b.offsets)[b.begin], na * sizeof(Ray));
}

// Appends the batches of `r` (and their answers) to `to` as one group.
template <typename Answer>
void append_group(const Range& r, const std::vector<Answer>& answers, RayBatches& to,
                  std::vector<Answer>& to_answers) {
  to.groups.push_back(static_cast<uint32_t>(to.sizes.size()));
  const size_t first = (*r.offsets)[r.begin], last = (*r.offsets)[r.end];
  to.rays.insert(to.rays.end(), r.from->rays.begin() + static_cast<ptrdiff_t>(first),
                 r.from->rays.begin() + static_cast<ptrdiff_t>(last));
  to.origins.insert(to.origins.end(), r.from->origins.begin() + static_cast<ptrdiff_t>(first),
                    r.from->origins.begin() + static_cast<ptrdiff_t>(last));
  to.sizes.insert(to.sizes.end(), r.from->sizes.begin() + r.begin, r.from->sizes.begin() + r.end);
  to_answers.insert(to_answers.end(), answers.begin() + static_cast<ptrdiff_t>(first),
                    answers.begin() + static_cast<ptrdiff_t>(last));
}

// Calls trace(rays, first) for every batch on `threads` threads, each taking the next group in
// order and tracing its batches in order (the renderer's set-up: parallel::on_threads).
template <typename Trace>
void for_each_batch(const RayBatches& batches, int threads, const Trace& trace) {
  const std::vector<size_t> offsets = batch_offsets(batches);
  const size_t groups = batches.groups.size();
  std::atomic<size_t> next{0};
  const auto run = [&] {
    for (size_t g = next.fetch_add(1, std::memory_order_relaxed); g < groups;
         g = next.fetch_add(1, std::memory_order_relaxed)) {
      const size_t end = g + 1 < groups ? batches.groups[g + 1] : batches.sizes.size();
      for (size_t k = batches.groups[g]; k < end; ++k) {
        const std::span<const uint32_t> origins =
            batches.origins.size() == batches.rays.size()
                ? std::span<const uint32_t>(batches.origins.data() + offsets[k], batches.sizes[k])
                : std::span<const uint32_t>();
        trace(std::span<const Ray>(batches.rays.data() + offsets[k], batches.sizes[k]), origins,
              offsets[k]);
      }
    }
  };
  parallel::on_threads(threads, run);
}

}  // namespace

RecordingAccel::Buffer& RecordingAccel::buffer() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::unique_ptr<Buffer>& b = buffers_[std::this_thread::get_id()];
  if (!b) b = std::make_unique<Buffer>();
  return *b;
}

void RecordingAccel::start_group(std::span<const Ray> rays) const {
  coherent_rays_.fetch_add(rays.size(), std::memory_order_relaxed);
  if (rays.empty()) return;
  Buffer& b = buffer();
  Group g;
  g.key_size = static_cast<uint32_t>(rays.size());
  g.key_first = rays[0];
  g.key_hash = fnv1a(rays);
  g.closest_begin = static_cast<uint32_t>(b.recorded.closest.sizes.size());
  g.any_begin = static_cast<uint32_t>(b.recorded.any.sizes.size());
  b.groups.push_back(g);
}

void RecordingAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  inner_.intersect(rays, hits);
  start_group(rays);
}

void RecordingAccel::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  inner_.occluded(rays, occluded);
  start_group(rays);
}

void RecordingAccel::intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const {
  intersect_incoherent_from(rays, {}, hits);
}

void RecordingAccel::occluded_incoherent(std::span<const Ray> rays,
                                         std::span<uint8_t> occluded) const {
  occluded_incoherent_from(rays, {}, occluded);
}

void RecordingAccel::intersect_incoherent_from(std::span<const Ray> rays,
                                               std::span<const uint32_t> origins,
                                               std::span<Hit> hits) const {
  inner_.intersect_incoherent_from(rays, origins, hits);
  Buffer& b = buffer();
  if (b.groups.empty()) b.groups.emplace_back();  // before any coherent query
  append(b.recorded.closest, rays, origins);
  b.recorded.hits.insert(b.recorded.hits.end(), hits.begin(),
                         hits.begin() + static_cast<ptrdiff_t>(rays.size()));
}

void RecordingAccel::occluded_incoherent_from(std::span<const Ray> rays,
                                              std::span<const uint32_t> origins,
                                              std::span<uint8_t> occluded) const {
  inner_.occluded_incoherent_from(rays, origins, occluded);
  Buffer& b = buffer();
  if (b.groups.empty()) b.groups.emplace_back();
  append(b.recorded.any, rays, origins);
  b.recorded.occluded.insert(b.recorded.occluded.end(), occluded.begin(),
                             occluded.begin() + static_cast<ptrdiff_t>(rays.size()));
}

RecordedRays RecordingAccel::take() {
  const std::lock_guard<std::mutex> lock(mutex_);
  struct GroupRef {
    const Group* group;
    Range closest, any;
    const Buffer* buffer;
  };
  // Per buffer, in the map's (arbitrary) order; the sort below fixes the order.
  std::vector<std::pair<std::vector<size_t>, std::vector<size_t>>> offsets;
  offsets.reserve(buffers_.size());
  std::vector<GroupRef> refs;
  for (const auto& [id, b] : buffers_) {
    const RecordedRays& r = b->recorded;
    offsets.emplace_back(batch_offsets(r.closest), batch_offsets(r.any));
    const auto& [closest_offsets, any_offsets] = offsets.back();
    for (size_t i = 0; i < b->groups.size(); ++i) {
      const Group& g = b->groups[i];
      const bool last = i + 1 == b->groups.size();
      const uint32_t closest_end =
          last ? static_cast<uint32_t>(r.closest.sizes.size()) : b->groups[i + 1].closest_begin;
      const uint32_t any_end =
          last ? static_cast<uint32_t>(r.any.sizes.size()) : b->groups[i + 1].any_begin;
      refs.push_back({&g,
                      {&r.closest, &closest_offsets, g.closest_begin, closest_end},
                      {&r.any, &any_offsets, g.any_begin, any_end},
                      b.get()});
    }
  }
  if (order_ == GroupOrder::kCallOrder && buffers_.size() > 1) {
    throw std::logic_error("RecordingAccel: call order needs every query on one thread");
  }
  if (order_ == GroupOrder::kSorted)
    std::sort(refs.begin(), refs.end(), [](const GroupRef& a, const GroupRef& b) {
      if (a.group->key_size != b.group->key_size) return a.group->key_size < b.group->key_size;
      const int first = std::memcmp(&a.group->key_first, &b.group->key_first, sizeof(Ray));
      if (first != 0) return first < 0;
      if (a.group->key_hash != b.group->key_hash) return a.group->key_hash < b.group->key_hash;
      const int closest = compare_first(a.closest, b.closest);
      if (closest != 0) return closest < 0;
      return compare_first(a.any, b.any) < 0;
    });
  RecordedRays out;
  for (const GroupRef& g : refs) {
    append_group(g.closest, g.buffer->recorded.hits, out.closest, out.hits);
    append_group(g.any, g.buffer->recorded.occluded, out.any, out.occluded);
  }
  out.coherent_rays = coherent_rays_.exchange(0);
  buffers_.clear();
  return out;
}

void replay_closest(const Accel& accel, const RayBatches& batches, std::span<Hit> hits,
                    int threads) {
  for_each_batch(batches, threads,
                 [&](std::span<const Ray> rays, std::span<const uint32_t> origins, size_t first) {
                   accel.intersect_incoherent_from(rays, origins, hits.subspan(first, rays.size()));
                 });
}

void replay_any(const Accel& accel, const RayBatches& batches, std::span<uint8_t> occluded,
                int threads) {
  for_each_batch(batches, threads,
                 [&](std::span<const Ray> rays, std::span<const uint32_t> origins, size_t first) {
                   accel.occluded_incoherent_from(rays, origins,
                                                  occluded.subspan(first, rays.size()));
                 });
}

}  // namespace tritrace
