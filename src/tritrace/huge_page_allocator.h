// HugePageAllocator: the allocator of big arrays (the BVH's nodes and triangle blocks, the mesh's
// triangles, the build's references). Arrays of 2 MiB or more are placed on 2 MiB boundaries and
// offered to the kernel's transparent huge pages (madvise), which Debian enables on request by
// default. Two reasons: incoherent rays through a big mesh reach nodes and leaves all over tens of
// MiB, so with 4 KiB pages nearly every visit also misses the TLB; and the first touch of fresh
// memory, most of loading and building a big mesh, costs several times less in 2 MiB pages than in
// 4 KiB pages (docs/PERFORMANCE.md, "A faster binned SAH build").
#pragma once

#include <cstddef>
#include <cstdlib>
#include <new>
#include <utility>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace tritrace {

inline constexpr size_t kHugePageBytes = size_t{2} << 20;

template <typename T>
struct HugePageAllocator {
  using value_type = T;

  HugePageAllocator() = default;
  template <typename U>
  HugePageAllocator(const HugePageAllocator<U>& /*other*/) {}

  T* allocate(size_t n) {
    if (n > std::size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
    const size_t bytes = n * sizeof(T);
    if (bytes < kHugePageBytes) {
      return static_cast<T*>(::operator new(bytes, std::align_val_t(alignof(T))));
    }
    const size_t rounded = (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    void* p = std::aligned_alloc(kHugePageBytes, rounded);
    if (!p) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    madvise(p, rounded, MADV_HUGEPAGE);  // a hint: where huge pages are off, nothing changes
#endif
    return static_cast<T*>(p);
  }

  void deallocate(T* p, size_t n) {
    if (n * sizeof(T) < kHugePageBytes) {
      ::operator delete(p, std::align_val_t(alignof(T)));
    } else {
      std::free(p);
    }
  }

  // Elements made without arguments are default-initialised, not zeroed: a resize of the block
  // array leaves its 425 MiB (terrain:10m) to be written once, in parallel, by its filler (and a
  // resize of a vector of floats leaves them indeterminate: fill what you resize).
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    if constexpr (sizeof...(Args) == 0) {
      ::new (static_cast<void*>(p)) U;
    } else {
      ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
  }

  template <typename U>
  bool operator==(const HugePageAllocator<U>& /*other*/) const {
    return true;
  }
};

// A vector whose elements live on huge pages once it holds 2 MiB or more.
template <typename T>
using HugePageVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace tritrace
