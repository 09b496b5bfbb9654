// The order in which a pixel's samples are summed: the rule that makes any split of the samples at
// multiples of 8, and any tiling, merge bit for bit into the one-process image.
//
// Float addition is not associative, so the sums must be formed in one fixed order whoever renders
// which samples. The order is a fixed tree over the sample index:
//   - block k holds samples [8k, 8k + 8); its sum is added in sample order, starting from zero;
//   - blocks are combined pairwise as in a binary counter: blocks 2i and 2i + 1 make node (1, i),
//     nodes (L, 2i) and (L, 2i + 1) make node (L + 1, i), always left + right. Node (L, i) covers
//     blocks [i 2^L, (i + 1) 2^L);
//   - what is left (the nodes of the binary digits of the block count, largest first, and a last
//     partial block) is added from the right: n0 + (n1 + (n2 + ...)).
// A renderer of samples [a, b) (a a multiple of 8) keeps the complete nodes inside [a, b) that are
// not yet paired; pushing those nodes, in sample order, into one counter performs exactly the
// additions pushing their blocks would (a node's left neighbours are never smaller than it), so
// parts merge into the whole render's bits. This is pairwise summation (Higham, "The accuracy of
// floating point summation", SIAM J. Sci. Comput. 14(4), 1993) over aligned blocks, which also
// keeps the rounding error growing with log2 of the sample count rather than with the count.
#pragma once

#include <array>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <span>

namespace tritrace {

inline constexpr uint32_t kSampleBlock = 8;

// Node (level, index) of the block tree: blocks [index 2^level, (index + 1) 2^level).
struct BlockNode {
  uint32_t level = 0;
  uint64_t index = 0;

  uint64_t first_block() const { return index << level; }
  uint64_t end_block() const { return (index + 1) << level; }
  uint64_t first_sample() const { return first_block() * kSampleBlock; }
  uint64_t end_sample() const { return end_block() * kSampleBlock; }
  bool operator==(const BlockNode&) const = default;
};

// The complete nodes not yet paired, in sample order. Samples are 32-bit indices, so a counter
// over any range of them holds at most 2 x 29 nodes.
class BlockCounter {
 public:
  static constexpr size_t kMaxNodes = 64;

  BlockCounter() = default;
  explicit BlockCounter(std::span<const BlockNode> nodes) {
    for (const BlockNode& n : nodes) push(n);
  }

  // Appends a complete node that starts where the last one ends (or anywhere when empty), then
  // replaces each pair of siblings on top by their parent. Returns the number of pairs merged: a
  // caller holding values per node merges its last two values that many times, left + right.
  int push(BlockNode node) {
    assert(size_ < kMaxNodes);
    nodes_[size_++] = node;
    int merges = 0;
    while (size_ >= 2) {
      const BlockNode top = nodes_[size_ - 1];
      const BlockNode below = nodes_[size_ - 2];
      if (top.level != below.level || (top.index & 1) == 0 || below.index + 1 != top.index) break;
      nodes_[size_ - 2] = BlockNode{top.level + 1, below.index >> 1};
      --size_;
      ++merges;
    }
    return merges;
  }

  // Pushes blocks [first, end) as the largest aligned nodes that fit, which leaves the nodes (and
  // performs the same pairings) that pushing the blocks one by one would, in O(log) steps.
  void push_blocks(uint64_t first, uint64_t end) {
    while (first < end) {
      uint32_t level = 0;
      while (level < 62 && (first & ((uint64_t{2} << level) - 1)) == 0 &&
             first + (uint64_t{2} << level) <= end) {
        ++level;
      }
      push(BlockNode{level, first >> level});
      first += uint64_t{1} << level;
    }
  }

  std::span<const BlockNode> nodes() const { return std::span(nodes_).first(size_); }
  size_t size() const { return size_; }

 private:
  std::array<BlockNode, kMaxNodes> nodes_{};
  size_t size_ = 0;
};

// The AOV sums of a pixel (albedo, normal, depth, each times the sample's weight), and the half
// buffer of the variance AOV: (sum of weight x radiance, sum of weights) over the samples whose
// global index is even. Only the even half is kept: the odd half is the pixel's total minus it,
// which saves 16 bytes per pixel and layer (the AOVs' cost is memory traffic) and, being formed
// in the same order as the total, merges as exactly. `samples` counts the samples the pixel took
// (the spp AOV; exact in a float up to 2^24, above kMaxSpp), summed like the rest, so that parts
// of an adaptive render merge into the one-process counts.
struct AovSums {
  glm::vec3 albedo{0.0f};
  glm::vec3 normal{0.0f};
  float depth = 0.0f;
  glm::vec4 even{0.0f};
  float samples = 0.0f;
};
inline AovSums operator+(const AovSums& a, const AovSums& b) {
  return {a.albedo + b.albedo, a.normal + b.normal, a.depth + b.depth, a.even + b.even,
          a.samples + b.samples};
}

// Replays `merges` merges on the values of a counter's nodes, values[0, count): the last two
// become their sum (left + right), `merges` times. Returns the new count.
template <typename T>
size_t merge_last(T* values, size_t count, int merges) {
  for (int m = 0; m < merges; ++m, --count) {
    values[count - 2] = values[count - 2] + values[count - 1];
  }
  return count;
}

// The sum of values[0, count) added from the right, n0 + (n1 + (... + n_last)): the one order in
// which what is left of a counter (and a last partial block) is combined. count >= 1.
template <typename T>
T fold_from_right(const T* values, size_t count, size_t stride = 1) {
  T sum = values[(count - 1) * stride];
  for (size_t k = count - 1; k-- > 0;) sum = values[k * stride] + sum;
  return sum;
}

}  // namespace tritrace
