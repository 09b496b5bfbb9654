// BufferCache: the memory of an accel's recent query results, kept for its next queries. Fresh
// memory for a million rays' results (16 MiB) costs the kernel about as much time to fault in and
// zero as tracing the rays does on a small scene; results freed and asked for again, as in a
// loop over lidar frames, reuse warm memory instead. Thread-safe; plain C++ (no Python).
#pragma once

#include <cstddef>
#include <mutex>
#include <utility>
#include <vector>

namespace tritrace::python {

class BufferCache {
 public:
  // Keeps at most `max_bytes` of released buffers (older ones are freed first).
  explicit BufferCache(size_t max_bytes) : max_bytes_(max_bytes) {}
  ~BufferCache();
  BufferCache(const BufferCache&) = delete;
  BufferCache& operator=(const BufferCache&) = delete;

  struct Buffer {
    void* data = nullptr;
    size_t capacity = 0;
  };
  // A 64-byte aligned buffer of at least `bytes`: a cached one no more than twice as large, else
  // a new one.
  Buffer take(size_t bytes);
  // Hands a buffer from take() back: cached, or freed when the cache would exceed its limit.
  void give(Buffer buffer);

 private:
  std::mutex mutex_;
  std::vector<Buffer> free_;  // oldest first
  size_t free_bytes_ = 0;
  size_t max_bytes_;
};

}  // namespace tritrace::python
