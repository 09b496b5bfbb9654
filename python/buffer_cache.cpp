// BufferCache: a short list searched for a buffer that fits, under one mutex (a query takes one
// buffer, so the list and the lock are touched once per query).
#include "buffer_cache.h"

#include <algorithm>
#include <cstdlib>
#include <new>

namespace tritrace::python {
namespace {

constexpr size_t kAlignment = 64;

}  // namespace

BufferCache::~BufferCache() {
  for (const Buffer& b : free_) std::free(b.data);
}

BufferCache::Buffer BufferCache::take(size_t bytes) {
  bytes = std::max(kAlignment, (bytes + kAlignment - 1) / kAlignment * kAlignment);
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (size_t i = free_.size(); i-- > 0;) {  // the most recently released first
      const Buffer b = free_[i];
      if (b.capacity >= bytes && b.capacity <= 2 * bytes) {
        free_.erase(free_.begin() + static_cast<std::ptrdiff_t>(i));
        free_bytes_ -= b.capacity;
        return b;
      }
    }
  }
  void* data = std::aligned_alloc(kAlignment, bytes);
  if (data == nullptr) throw std::bad_alloc();
  return {data, bytes};
}

void BufferCache::give(Buffer buffer) {
  std::vector<Buffer> evicted;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (buffer.capacity > max_bytes_) {
      evicted.push_back(buffer);
    } else {
      free_.push_back(buffer);
      free_bytes_ += buffer.capacity;
      while (free_bytes_ > max_bytes_) {
        evicted.push_back(free_.front());
        free_bytes_ -= free_.front().capacity;
        free_.erase(free_.begin());
      }
    }
  }
  for (const Buffer& b : evicted) std::free(b.data);
}

}  // namespace tritrace::python
