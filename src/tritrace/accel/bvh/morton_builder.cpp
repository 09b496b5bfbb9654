// Morton-code construction in three parallel steps: box centres quantised to 10 bits per axis and
// interleaved into 30-bit codes, each stored above its primitive's index in a 64-bit key (so keys
// are distinct and the sort's result is unique); the keys sorted by a least-significant-digit
// radix sort over the code bits; then ranges split top-down at the highest bit in which their
// first and last codes differ (a binary search in the sorted codes), in tasks for large ranges,
// each node written at its depth-first place, with its box the union of its children's, computed
// on the way back up.
#include "tritrace/accel/bvh/morton_builder.h"

#include <tbb/blocked_range.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <numeric>
#include <vector>

#include "tritrace/huge_page_allocator.h"
#include "tritrace/parallel.h"

namespace tritrace::bvh {
namespace {

constexpr int kBitsPerAxis = 10;
constexpr uint32_t kCells = 1u << kBitsPerAxis;
constexpr int kCodeShift = 32;  // a key is code << 32 | primitive index
constexpr int kDigitBits = 10;
constexpr uint32_t kDigits = 1u << kDigitBits;
constexpr int kPasses = 3 * kBitsPerAxis / kDigitBits;
// Ranges at least this large get their own tasks (the build) or are split into chunks (the sort).
constexpr uint32_t kParallelThreshold = 1u << 14;

// The low 10 bits of x moved to every third bit: bit k to bit 3k.
uint32_t spread_bits(uint32_t x) {
  x &= kCells - 1;
  x = (x | (x << 16)) & 0x030000FFu;
  x = (x | (x << 8)) & 0x0300F00Fu;
  x = (x | (x << 4)) & 0x030C30C3u;
  x = (x | (x << 2)) & 0x09249249u;
  return x;
}

// A box's centre without overflow for any finite box.
glm::vec3 centre_of(const Bounds3& b) {
  return 0.5f * b.lo + 0.5f * b.hi;
}

// Maps centres to Morton codes over the bounds of all centres. An axis whose extent is zero, or
// too small or too large for cells / extent to be a finite float, puts every centre in cell 0.
class MortonGrid {
 public:
  explicit MortonGrid(const Bounds3& centres) : lo_(centres.lo) {
    for (int a = 0; a < 3; ++a) {
      const double extent = double{centres.hi[a]} - double{centres.lo[a]};
      const double scale = extent > 0.0 ? kCells / extent : 0.0;
      scale_[a] = scale > 0.0 && scale <= double{std::numeric_limits<float>::max()}
                      ? static_cast<float>(scale)
                      : 0.0f;
    }
  }
  uint32_t code(const glm::vec3& c) const {
    uint32_t out = 0;
    for (int a = 0; a < 3; ++a) {
      // Clamped in float before the cast, which is undefined for NaN, inf and out-of-range values.
      const float x = (c[a] - lo_[a]) * scale_[a];
      const uint32_t cell =
          x > 0.0f ? static_cast<uint32_t>(std::min(x, static_cast<float>(kCells - 1))) : 0u;
      out |= spread_bits(cell) << (2 - a);  // x in the highest of each three bits
    }
    return out;
  }

 private:
  glm::vec3 lo_;
  glm::vec3 scale_{0.0f};
};

uint32_t code_of(uint64_t key) {
  return static_cast<uint32_t>(key >> kCodeShift);
}
uint32_t prim_of(uint64_t key) {
  return static_cast<uint32_t>(key);
}

// Sorts the keys by their code bits, least significant digit first; each pass is stable, so keys
// of equal code keep their index order. Chunks count their digits, then write them to the places
// that the counts of all chunks before them give.
void radix_sort(HugePageVector<uint64_t>& keys) {
  const size_t n = keys.size();
  HugePageVector<uint64_t> other(n);
  const size_t chunks = std::clamp<size_t>(n / kParallelThreshold, 1, 64);
  auto chunk_begin = [&](size_t c) { return n * c / chunks; };
  std::vector<std::array<uint32_t, kDigits>> place(chunks);
  const tbb::blocked_range<size_t> all_chunks(0, chunks, 1);
  for (int pass = 0; pass < kPasses; ++pass) {
    const int shift = kCodeShift + pass * kDigitBits;
    auto digit = [shift](uint64_t key) {
      return static_cast<uint32_t>(key >> shift) & (kDigits - 1);
    };
    parallel::for_range(all_chunks, [&](const tbb::blocked_range<size_t>& r) {
      for (size_t c = r.begin(); c != r.end(); ++c) {
        place[c].fill(0);
        for (size_t i = chunk_begin(c); i != chunk_begin(c + 1); ++i) ++place[c][digit(keys[i])];
      }
    });
    // A pass whose digit is the same for every key would copy them in order: skipped.
    const uint32_t first_digit = digit(keys[0]);
    size_t with_first = 0;
    for (size_t c = 0; c < chunks; ++c) with_first += place[c][first_digit];
    if (with_first == n) continue;
    uint32_t next = 0;
    for (uint32_t d = 0; d < kDigits; ++d) {
      for (size_t c = 0; c < chunks; ++c) {
        const uint32_t count = place[c][d];
        place[c][d] = next;
        next += count;
      }
    }
    parallel::for_range(all_chunks, [&](const tbb::blocked_range<size_t>& r) {
      for (size_t c = r.begin(); c != r.end(); ++c) {
        std::array<uint32_t, kDigits>& at = place[c];
        for (size_t i = chunk_begin(c); i != chunk_begin(c + 1); ++i) {
          other[at[digit(keys[i])]++] = keys[i];
        }
      }
    });
    keys.swap(other);
  }
}

class MortonTreeBuilder {
 public:
  // Builds into `out`.
  MortonTreeBuilder(const HugePageVector<uint64_t>& keys, const BoxSource& boxes,
                    uint32_t max_leaf_size, BinaryBvh& out)
      : keys_(keys), boxes_(boxes), max_leaf_size_(max_leaf_size), out_(out) {}

  // Every range starts at a multiple of the leaf size, so a subtree over n primitives has exactly
  // ceil(n / leaf size) leaves and twice that less one nodes: the tree is laid out in depth-first
  // order as it is built, each node's place known from its range alone, the same whatever the
  // threads.
  void build() {
    const uint32_t n = static_cast<uint32_t>(keys_.size());
    if (n == 0) return;
    out_.nodes.resize(subtree_nodes(n));
    build_node(0, 0, n);
    out_.prim_index.resize(n);
    parallel::for_range(tbb::blocked_range<size_t>(0, n, 1 << 16), [&](const auto& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) out_.prim_index[i] = prim_of(keys_[i]);
    });
  }

 private:
  // Where [begin, end) splits: at the multiple of the leaf size nearest the first key whose code
  // has the highest differing bit set (or nearest the middle where all codes are equal). Ranges
  // then start at multiples of the leaf size, so that every leaf but the last is full: a leaf is
  // one SIMD block, which costs the same whether it holds one triangle or eight.
  uint32_t split(uint32_t begin, uint32_t end) const {
    const uint32_t first = code_of(keys_[begin]), last = code_of(keys_[end - 1]);
    uint32_t at = begin + (end - begin) / 2;
    if (first != last) {
      const uint32_t bit = std::bit_floor(first ^ last);  // the highest differing bit
      // The codes share every bit above `bit` and are sorted, so those without it come first.
      uint32_t lo = begin + 1, hi = end - 1;  // the answer lies in [lo, hi]
      while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (code_of(keys_[mid]) & bit) {
          hi = mid;
        } else {
          lo = mid + 1;
        }
      }
      at = lo;
    }
    // begin is a multiple of the leaf size and end - begin exceeds it, so a multiple lies in
    // [begin + leaf, end - 1].
    const uint32_t leaf = max_leaf_size_;
    const uint32_t rounded = (at + leaf / 2) / leaf * leaf;
    return std::clamp(rounded, begin + leaf, (end - 1) / leaf * leaf);
  }

  uint32_t subtree_nodes(uint32_t count) const {
    return 2 * ((count + max_leaf_size_ - 1) / max_leaf_size_) - 1;
  }

  // Fills node `index` and the nodes after it with the subtree of keys [begin, end) and returns
  // its box.
  Bounds3 build_node(uint32_t index, uint32_t begin, uint32_t end) {
    const uint32_t count = end - begin;
    if (count <= max_leaf_size_) {
      Bounds3 bounds = Bounds3::empty();
      for (uint32_t i = begin; i != end; ++i) {
        const uint32_t p = prim_of(keys_[i]);
        Bounds3 b;
        boxes_(p, p + 1, &b);
        bounds.extend(b);
      }
      BinaryNode& node = out_.nodes[index];
      node.bounds = bounds;
      node.count = count;
      node.first = begin;
      return bounds;
    }
    const uint32_t mid = split(begin, end);
    const uint32_t left = index + 1, right = left + subtree_nodes(mid - begin);
    Bounds3 left_bounds, right_bounds;
    if (count >= kParallelThreshold) {
      parallel::TaskGroup group;
      group.run([&] { left_bounds = build_node(left, begin, mid); });
      right_bounds = build_node(right, mid, end);
      group.wait();
    } else {
      left_bounds = build_node(left, begin, mid);
      right_bounds = build_node(right, mid, end);
    }
    Bounds3 bounds = left_bounds;
    bounds.extend(right_bounds);
    BinaryNode& node = out_.nodes[index];
    node.bounds = bounds;
    node.count = 0;
    node.first = left;
    node.right = right;
    return bounds;
  }

  const HugePageVector<uint64_t>& keys_;
  const BoxSource& boxes_;
  uint32_t max_leaf_size_;
  BinaryBvh& out_;
};

}  // namespace

BinaryBvh build_morton(size_t count, const BoxSource& boxes, const BuildConfig& config) {
  check_build_config(count, config);
  if (count == 0) return {};
  // Every primitive's box is made twice (centres' bounds, then codes) and once more for its leaf:
  // a mesh's boxes are cheaper to remake than 24 bytes per primitive of fresh memory.
  const tbb::blocked_range<size_t> all(0, count, kBoxBatch);
  auto for_boxes = [&](const tbb::blocked_range<size_t>& r, auto&& visit) {
    Bounds3 batch[kBoxBatch];
    for (size_t first = r.begin(); first < r.end(); first += kBoxBatch) {
      const size_t last = std::min(r.end(), first + kBoxBatch);
      boxes(first, last, batch);
      for (size_t i = first; i != last; ++i) visit(i, batch[i - first]);
    }
  };
  const Bounds3 centres = parallel::reduce(
      all, Bounds3::empty(),
      [&](const tbb::blocked_range<size_t>& r, Bounds3 acc) {
        for_boxes(r, [&](size_t, const Bounds3& b) { acc.extend(centre_of(b)); });
        return acc;
      },
      [](Bounds3 a, const Bounds3& b) {
        a.extend(b);
        return a;
      });
  const MortonGrid grid(centres);
  HugePageVector<uint64_t> keys(count);
  parallel::for_range(all, [&](const tbb::blocked_range<size_t>& r) {
    for_boxes(r, [&](size_t i, const Bounds3& b) {
      keys[i] = uint64_t{grid.code(centre_of(b))} << kCodeShift | i;
    });
  });
  radix_sort(keys);
  BinaryBvh out;
  MortonTreeBuilder(keys, boxes, config.max_leaf_size, out).build();
  return out;
}

}  // namespace tritrace::bvh
