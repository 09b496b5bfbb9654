// Binned SAH construction. Each task splits one node's range of primitive references (box and
// index, 32 bytes, moved by the partition so that every pass reads memory in order): it bins
// centroids along all three axes with SSE, sweeps the bins for the cheapest plane, partitions in
// place without branches and recurses, spawning a task for large halves. A child's box comes from
// its side's bins, its centroid bounds from the partition, so a node reads its references twice
// (bin, partition). Nodes go into a concurrent vector; a node's index is reserved before its
// children are built, so the tree needs no fix-up pass. SAH costs are computed in double where
// float's would overflow (box areas beyond about 1e19); bin indices are clamped in float before
// the cast to int, which is undefined for inf and NaN.
#include "tritrace/accel/bvh/binned_sah_builder.h"

#include <immintrin.h>
#include <tbb/blocked_range.h>
#include <tbb/concurrent_vector.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "tritrace/parallel.h"

namespace tritrace::bvh {
namespace {

constexpr int kMaxBins = 32;
// Below this depth splits halve the range instead, which bounds the tree's depth (and so the
// traversal stack) by kMaxSahDepth + log2(n) whatever the input.
constexpr uint32_t kMaxSahDepth = 64;

struct Bin {
  Bounds3 bounds = Bounds3::empty();
  uint32_t count = 0;
};

// Surface area in Real. In double it is finite for every finite box (in float it is inf beyond
// about 1e19), so that SAH costs compare as numbers instead of inf against inf.
template <typename Real>
Real area_as(const Bounds3& b) {
  if (b.is_empty()) return Real{0};
  const Real x = Real{b.hi.x} - Real{b.lo.x}, y = Real{b.hi.y} - Real{b.lo.y},
             z = Real{b.hi.z} - Real{b.lo.z};
  return Real{2} * (x * y + y * z + z * x);
}

struct Split {
  double cost = std::numeric_limits<double>::infinity();  // SAH cost, not yet divided by the area
  int axis = -1;                                          // -1: no split found
  int bin = 0;                                            // first bin of the right half
};

// Maps a centroid coordinate to its bin along one axis of a node's centroid bounds, in float (the
// build's innermost loop). An axis is split only where bins / extent is a finite float: not for a
// zero, denormal or non-finite extent, whose range is then halved instead.
struct AxisBins {
  float lo = 0.0f;
  float scale = 0.0f;  // bins / extent
  float last = 0.0f;   // bins - 1
  bool splittable = false;

  AxisBins() = default;
  AxisBins(float lo_f, float hi_f, int bins) : lo(lo_f), last(static_cast<float>(bins - 1)) {
    // In double: hi - lo of finite floats cannot overflow, nor bins / extent for a denormal one.
    const double extent = double{hi_f} - lo;
    const double scale_d = extent > 0.0 ? bins / extent : 0.0;
    splittable = std::isfinite(extent) && scale_d > 0.0 &&
                 scale_d <= double{std::numeric_limits<float>::max()};
    scale = splittable ? static_cast<float>(scale_d) : 0.0f;
  }
  int bin_of(float c) const {
    // Clamped in float before the cast, so that the cast is defined for any x, NaN and inf
    // included (c - lo overflows to inf for centroids more than FLT_MAX apart).
    const float x = (c - lo) * scale;
    if (!(x > 0.0f)) return 0;
    return static_cast<int>(std::min(x, last));
  }
};

// A primitive's box with its index, in the layout the build works on: two SSE registers, so that
// centroids, bin indices and bin bounds take a few vector instructions, and the references move
// with the partition (the build reads them in order instead of gathering boxes by index, which on
// a big mesh would spend most of the build waiting on memory).
struct alignas(32) PrimRef {
  float lo[3];
  uint32_t id;
  float hi[3];
  float unused;  // no initialiser: the array of references is first written in parallel
};
static_assert(sizeof(PrimRef) == 32);

// Lane 3 of lo and hi zeroed (lo's holds the index, whose bits must not reach float arithmetic).
inline __m128 lo_of(const PrimRef& r) {
  return _mm_blend_ps(_mm_load_ps(r.lo), _mm_setzero_ps(), 0b1000);
}
inline __m128 hi_of(const PrimRef& r) {
  return _mm_blend_ps(_mm_load_ps(r.hi), _mm_setzero_ps(), 0b1000);
}

// A box's centroid, Bounds3::centre() lane by lane, except where lo + hi overflows float (bounds
// beyond about 1.7e38): there the halves are summed instead, which cannot overflow. (Halving first
// everywhere would round denormal centroids.)
inline __m128 centroid4(__m128 lo, __m128 hi) {
  const __m128 half = _mm_set1_ps(0.5f);
  const __m128 c = _mm_mul_ps(_mm_add_ps(lo, hi), half);
  const __m128 abs_c = _mm_andnot_ps(_mm_set1_ps(-0.0f), c);
  const __m128 finite =
      _mm_cmp_ps(abs_c, _mm_set1_ps(std::numeric_limits<float>::max()), _CMP_LE_OQ);
  if (_mm_movemask_ps(finite) == 0xF) return c;
  const __m128 halves = _mm_add_ps(_mm_mul_ps(lo, half), _mm_mul_ps(hi, half));
  return _mm_blendv_ps(halves, c, finite);
}

// AxisBins::bin_of for the three axes at once (lane 3 gives 0).
struct AxisBins4 {
  __m128 lo, scale, last;
  explicit AxisBins4(const std::array<AxisBins, 3>& axes)
      : lo(_mm_setr_ps(axes[0].lo, axes[1].lo, axes[2].lo, 0.0f)),
        scale(_mm_setr_ps(axes[0].scale, axes[1].scale, axes[2].scale, 0.0f)),
        last(_mm_setr_ps(axes[0].last, axes[1].last, axes[2].last, 0.0f)) {}
  __m128i bins_of(__m128 c) const {
    const __m128 x = _mm_mul_ps(_mm_sub_ps(c, lo), scale);
    // min(x, last) is last for a NaN x, and the mask (x > 0) is false for it: 0, as bin_of gives.
    const __m128 positive = _mm_cmp_ps(x, _mm_setzero_ps(), _CMP_GT_OQ);
    return _mm_cvttps_epi32(_mm_and_ps(positive, _mm_min_ps(x, last)));
  }
};

struct BinSet {
  // Lanes 0-2 of each bin's lo and hi; the bins are turned into Bounds3 for the sweep.
  __m128 lo[3][kMaxBins], hi[3][kMaxBins];
  uint32_t count[3][kMaxBins];

  explicit BinSet(int bins) {
    const __m128 inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
    const __m128 minus_inf = _mm_set1_ps(-std::numeric_limits<float>::infinity());
    for (int a = 0; a < 3; ++a) {
      for (int i = 0; i < bins; ++i) lo[a][i] = inf, hi[a][i] = minus_inf, count[a][i] = 0;
    }
  }
  void merge(const BinSet& o, int bins) {
    for (int a = 0; a < 3; ++a) {
      for (int i = 0; i < bins; ++i) {
        lo[a][i] = _mm_min_ps(lo[a][i], o.lo[a][i]);
        hi[a][i] = _mm_max_ps(hi[a][i], o.hi[a][i]);
        count[a][i] += o.count[a][i];
      }
    }
  }
  Bounds3 bounds(int a, int i) const {
    alignas(16) float l[4], h[4];
    _mm_store_ps(l, lo[a][i]);
    _mm_store_ps(h, hi[a][i]);
    return {glm::vec3(l[0], l[1], l[2]), glm::vec3(h[0], h[1], h[2])};
  }
};

Bounds3 to_bounds(__m128 lo, __m128 hi) {
  alignas(16) float l[4], h[4];
  _mm_store_ps(l, lo);
  _mm_store_ps(h, hi);
  return {glm::vec3(l[0], l[1], l[2]), glm::vec3(h[0], h[1], h[2])};
}

// area_as<float> of a non-empty box in lanes 0-2: 2 (xy + yz + zx), summed in that order.
inline float area4(__m128 lo, __m128 hi) {
  const __m128 e = _mm_sub_ps(hi, lo);
  const __m128 p = _mm_mul_ps(e, _mm_shuffle_ps(e, e, _MM_SHUFFLE(3, 0, 2, 1)));  // xy yz zx
  const __m128 sum = _mm_add_ss(_mm_add_ss(p, _mm_movehdup_ps(p)), _mm_movehl_ps(p, p));
  return 2.0f * _mm_cvtss_f32(sum);
}

// Bounds of primitives and of their centroids, as SSE registers.
struct RangeBounds {
  __m128 lo = _mm_set1_ps(std::numeric_limits<float>::infinity());
  __m128 hi = _mm_set1_ps(-std::numeric_limits<float>::infinity());
  __m128 c_lo = _mm_set1_ps(std::numeric_limits<float>::infinity());
  __m128 c_hi = _mm_set1_ps(-std::numeric_limits<float>::infinity());
  void extend(__m128 l, __m128 h, __m128 c) {
    lo = _mm_min_ps(lo, l), hi = _mm_max_ps(hi, h);
    c_lo = _mm_min_ps(c_lo, c), c_hi = _mm_max_ps(c_hi, c);
  }
  void extend(const RangeBounds& o) {
    lo = _mm_min_ps(lo, o.lo), hi = _mm_max_ps(hi, o.hi);
    c_lo = _mm_min_ps(c_lo, o.c_lo), c_hi = _mm_max_ps(c_hi, o.c_hi);
  }
};

class Builder {
 public:
  Builder(size_t count, const BoxSource& boxes, const BuildConfig& config)
      : config_(config), refs_(count) {
    config_.bins = std::clamp(config_.bins, 2, kMaxBins);
    if (std::has_single_bit(config_.block_size))
      block_shift_ = std::countr_zero(config_.block_size);
    parallel::for_range(tbb::blocked_range<size_t>(0, count, kBoxBatch), [&](const auto& r) {
      Bounds3 batch[kBoxBatch];
      for (size_t first = r.begin(); first < r.end(); first += kBoxBatch) {
        const size_t last = std::min(r.end(), first + kBoxBatch);
        boxes(first, last, batch);
        for (size_t i = first; i != last; ++i) {
          const Bounds3& b = batch[i - first];
          refs_[i] = PrimRef{
              {b.lo.x, b.lo.y, b.lo.z}, static_cast<uint32_t>(i), {b.hi.x, b.hi.y, b.hi.z}, 0.0f};
        }
      }
    });
  }

  BinaryBvh build() {
    BinaryBvh out;
    const uint32_t n = static_cast<uint32_t>(refs_.size());
    if (n == 0) return out;
    nodes_.reserve(2 * (n / std::max(1u, config_.max_leaf_size / 2)) + 1);
    const uint32_t root = static_cast<uint32_t>(nodes_.grow_by(1) - nodes_.begin());
    parallel::TaskGroup group;
    build_node(root, 0, n, 0, range_bounds(0, n), group);
    group.wait();
    out.nodes.assign(nodes_.begin(), nodes_.end());
    out.prim_index.resize(n);
    parallel::for_range(tbb::blocked_range<size_t>(0, n), [&](const auto& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) out.prim_index[i] = refs_[i].id;
    });
    return out;
  }

 private:
  template <typename Real = double>
  Real leaf_cost(uint32_t count) const {
    // Rounded up; a shift for the usual power-of-two block sizes (the sweeps ask for this 90 times
    // a node, which makes a division here a noticeable share of the build).
    const uint32_t blocks = block_shift_ >= 0
                                ? (count + config_.block_size - 1) >> block_shift_
                                : (count + config_.block_size - 1) / config_.block_size;
    return static_cast<Real>(config_.block_cost) * static_cast<Real>(blocks);
  }

  // Centroid bounds and primitive bounds of a range (the root's, and both halves of a range split
  // in half; a binned split gets its halves' bounds from the bins and the partition).
  RangeBounds range_bounds(uint32_t begin, uint32_t end) const {
    auto body = [&](const tbb::blocked_range<uint32_t>& r, RangeBounds acc) {
      for (uint32_t i = r.begin(); i != r.end(); ++i) {
        const __m128 lo = lo_of(refs_[i]), hi = hi_of(refs_[i]);
        acc.extend(lo, hi, centroid4(lo, hi));
      }
      return acc;
    };
    if (end - begin < config_.parallel_threshold) {
      return body(tbb::blocked_range<uint32_t>(begin, end), RangeBounds{});
    }
    return parallel::reduce(tbb::blocked_range<uint32_t>(begin, end, 4096), RangeBounds{}, body,
                            [](RangeBounds a, const RangeBounds& b) {
                              a.extend(b);
                              return a;
                            });
  }

  BinSet bin_range(uint32_t begin, uint32_t end, const AxisBins4& axes) const {
    // Two bin sets, taking alternate references: consecutive references (neighbours in space after
    // the partitions above) mostly fall in the same bins, and with one set each update would wait
    // for the previous one's store.
    auto add = [&](BinSet& set, uint32_t i) {
      const __m128 lo = lo_of(refs_[i]), hi = hi_of(refs_[i]);
      alignas(16) int32_t bin[4];
      _mm_store_si128(reinterpret_cast<__m128i*>(bin), axes.bins_of(centroid4(lo, hi)));
      for (int a = 0; a < 3; ++a) {
        set.lo[a][bin[a]] = _mm_min_ps(set.lo[a][bin[a]], lo);
        set.hi[a][bin[a]] = _mm_max_ps(set.hi[a][bin[a]], hi);
        ++set.count[a][bin[a]];
      }
    };
    auto body = [&](const tbb::blocked_range<uint32_t>& r, BinSet acc) {
      if (r.size() < 64) {  // not worth a second set's initialisation and merge
        for (uint32_t i = r.begin(); i != r.end(); ++i) add(acc, i);
        return acc;
      }
      BinSet other(config_.bins);
      uint32_t i = r.begin();
      for (; i + 1 < r.end(); i += 2) add(acc, i), add(other, i + 1);
      if (i < r.end()) add(acc, i);
      acc.merge(other, config_.bins);
      return acc;
    };
    if (end - begin < config_.parallel_threshold) {
      return body(tbb::blocked_range<uint32_t>(begin, end), BinSet(config_.bins));
    }
    const BinSet empty(config_.bins);
    return parallel::reduce(tbb::blocked_range<uint32_t>(begin, end, 4096), empty, body,
                            [&](BinSet a, const BinSet& b) {
                              a.merge(b, config_.bins);
                              return a;
                            });
  }

  // The cheapest split of `count` primitives binned in `bins`, with costs computed in Real.
  template <typename Real>
  Split best_split(const std::array<std::array<Bounds3, kMaxBins>, 3>& bounds, const BinSet& bins,
                   const std::array<AxisBins, 3>& axes, uint32_t count) const {
    Split best;
    Real best_cost = std::numeric_limits<Real>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (!axes[a].splittable) continue;
      std::array<Real, kMaxBins> right_cost{};
      Bounds3 acc = Bounds3::empty();
      uint32_t n = 0;
      for (int i = config_.bins - 1; i > 0; --i) {
        acc.extend(bounds[a][i]);
        n += bins.count[a][i];
        right_cost[i] = n > 0 ? area_as<Real>(acc) * leaf_cost<Real>(n) : Real{0};
      }
      acc = Bounds3::empty();
      n = 0;
      for (int i = 0; i < config_.bins - 1; ++i) {
        acc.extend(bounds[a][i]);
        n += bins.count[a][i];
        if (n == 0 || n == count) continue;
        const Real cost = area_as<Real>(acc) * leaf_cost<Real>(n) + right_cost[i + 1];
        if (cost < best_cost) {
          best_cost = cost;
          best.axis = a;
          best.bin = i + 1;
        }
      }
    }
    best.cost = best_cost;
    return best;
  }

  // best_split<float> on the bins as they are, without turning them into Bounds3, and over the
  // occupied bins only: a split just after an empty bin costs exactly what the split before that
  // bin costs, and the first of equal costs wins, so skipping them chooses the same split. (Most
  // nodes are small, with few of their 48 bins occupied, so most of a full sweep is wasted work.)
  Split best_split_float(const BinSet& bins, const std::array<AxisBins, 3>& axes) const {
    Split best;
    float best_cost = std::numeric_limits<float>::infinity();
    const __m128 inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
    const __m128 minus_inf = _mm_set1_ps(-std::numeric_limits<float>::infinity());
    for (int a = 0; a < 3; ++a) {
      if (!axes[a].splittable) continue;
      int occupied[kMaxBins];
      int m = 0;
      for (int i = 0; i < config_.bins; ++i) {
        occupied[m] = i;
        m += bins.count[a][i] > 0 ? 1 : 0;
      }
      if (m < 2) continue;
      float right_cost[kMaxBins];  // of the occupied bins from the j-th on
      __m128 lo = inf, hi = minus_inf;
      uint32_t n = 0;
      for (int j = m - 1; j > 0; --j) {
        const int i = occupied[j];
        lo = _mm_min_ps(lo, bins.lo[a][i]), hi = _mm_max_ps(hi, bins.hi[a][i]);
        n += bins.count[a][i];
        right_cost[j] = area4(lo, hi) * leaf_cost<float>(n);
      }
      lo = inf, hi = minus_inf;
      n = 0;
      for (int j = 0; j < m - 1; ++j) {
        const int i = occupied[j];
        lo = _mm_min_ps(lo, bins.lo[a][i]), hi = _mm_max_ps(hi, bins.hi[a][i]);
        n += bins.count[a][i];
        const float cost = area4(lo, hi) * leaf_cost<float>(n) + right_cost[j + 1];
        if (cost < best_cost) {
          best_cost = cost;
          best.axis = a;
          best.bin = i + 1;
        }
      }
    }
    best.cost = best_cost;
    return best;
  }

  // Moves the references whose centroid falls in a bin below `split` along `axis` to the front of
  // [begin, end) and returns where the second half starts, extending each half's centroid bounds
  // by its references' centroids (its primitive bounds come from the bins). The same permutation
  // whatever the threads. Branch-free in the way of BlockQuicksort (Edelkamp and Weiss,
  // "BlockQuicksort: Avoiding Branch Mispredictions in Quicksort", ESA 2016): blocks of kBlock
  // references are classified from both ends without branches, recording the offsets of those on
  // the wrong side, which are then swapped in pairs; a branchy Hoare partition of the unknown
  // middle (at most two blocks) finishes. A centroid may be added to its half's bounds twice, which
  // min and max allow.
  uint32_t partition(uint32_t begin, uint32_t end, const AxisBins4& axes, int axis, int split,
                     RangeBounds& left, RangeBounds& right) {
    const __m128i split4 = _mm_set1_epi32(split);
    const __m128i lane = _mm_set1_epi32(axis);
    const __m128 inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
    const __m128 minus_inf = _mm_set1_ps(-std::numeric_limits<float>::infinity());
    __m128 l_lo = left.c_lo, l_hi = left.c_hi, r_lo = right.c_lo, r_hi = right.c_hi;
    // Whether reference i goes left (all bits of the result set) or right (none).
    auto classify = [&](uint32_t i) {
      const __m128 c = centroid4(lo_of(refs_[i]), hi_of(refs_[i]));
      const __m128i below = _mm_cmplt_epi32(axes.bins_of(c), split4);
      const __m128 goes_left = _mm_permutevar_ps(_mm_castsi128_ps(below), lane);
      l_lo = _mm_min_ps(l_lo, _mm_blendv_ps(inf, c, goes_left));
      l_hi = _mm_max_ps(l_hi, _mm_blendv_ps(minus_inf, c, goes_left));
      r_lo = _mm_min_ps(r_lo, _mm_blendv_ps(c, inf, goes_left));
      r_hi = _mm_max_ps(r_hi, _mm_blendv_ps(c, minus_inf, goes_left));
      return _mm_movemask_ps(goes_left) & 1;
    };

    constexpr uint32_t kBlock = 64;
    uint8_t wrong_left[kBlock], wrong_right[kBlock];  // offsets into the blocks at l and at r
    uint32_t l = begin, r = end;                      // [l, r) not yet placed
    uint32_t n_left = 0, n_right = 0, first_left = 0, first_right = 0;
    while (r - l > 2 * kBlock) {
      if (n_left == 0) {
        first_left = 0;
        for (uint32_t k = 0; k < kBlock; ++k) {
          wrong_left[n_left] = static_cast<uint8_t>(k);
          n_left += 1 - classify(l + k);
        }
      }
      if (n_right == 0) {
        first_right = 0;
        for (uint32_t k = 0; k < kBlock; ++k) {
          wrong_right[n_right] = static_cast<uint8_t>(k);
          n_right += classify(r - 1 - k);
        }
      }
      const uint32_t pairs = std::min(n_left, n_right);
      for (uint32_t k = 0; k < pairs; ++k) {
        std::swap(refs_[l + wrong_left[first_left + k]],
                  refs_[r - 1 - wrong_right[first_right + k]]);
      }
      n_left -= pairs, n_right -= pairs, first_left += pairs, first_right += pairs;
      if (n_left == 0) l += kBlock;
      if (n_right == 0) r -= kBlock;
    }
    // The middle, which may hold a block still partly out of place.
    while (true) {
      while (l < r && classify(l)) ++l;
      while (l < r && !classify(r - 1)) --r;
      if (l >= r) break;
      std::swap(refs_[l], refs_[r - 1]);
      ++l, --r;
    }
    left.c_lo = l_lo, left.c_hi = l_hi, right.c_lo = r_lo, right.c_hi = r_hi;
    return l;
  }

  void make_leaf(uint32_t index, uint32_t begin, uint32_t count, const Bounds3& bounds) {
    BinaryNode& node = nodes_[index];
    node.bounds = bounds;
    node.first = begin;
    node.count = count;
  }

  void build_node(uint32_t index, uint32_t begin, uint32_t end, uint32_t depth,
                  const RangeBounds& range, parallel::TaskGroup& group) {
    const uint32_t count = end - begin;
    const Bounds3 bounds = to_bounds(range.lo, range.hi);
    const Bounds3 cb = to_bounds(range.c_lo, range.c_hi);

    // Find the cheapest binned split over the three axes.
    std::array<AxisBins, 3> axes;
    for (int a = 0; a < 3; ++a) axes[a] = AxisBins(cb.lo[a], cb.hi[a], config_.bins);
    const AxisBins4 axes4(axes);
    const double parent_area = area_as<double>(bounds);
    Split best;
    const BinSet bins = count > 1 ? bin_range(begin, end, axes4) : BinSet(config_.bins);
    if (count > 1) {
      // Float is enough here, and faster, wherever no cost can overflow: every box swept lies
      // inside the node's, so a cost is below twice its area times the cost of a leaf of all its
      // primitives.
      const double largest_cost = 2.0 * parent_area * leaf_cost(count);
      if (largest_cost < 0.25 * std::numeric_limits<float>::max()) {
        best = best_split_float(bins, axes);
      } else {
        std::array<std::array<Bounds3, kMaxBins>, 3> bin_bounds;
        for (int a = 0; a < 3; ++a) {
          for (int i = 0; i < config_.bins; ++i) bin_bounds[a][i] = bins.bounds(a, i);
        }
        best = best_split<double>(bin_bounds, bins, axes, count);
      }
    }

    if (count <= config_.max_leaf_size) {
      const double split_cost =
          config_.traversal_cost + (parent_area > 0.0 ? best.cost / parent_area : 0.0);
      // Written so that a NaN cost (only from boxes outside the input contract) makes a leaf.
      if (best.axis < 0 || !(leaf_cost(count) > split_cost)) {
        return make_leaf(index, begin, count, bounds);
      }
    }

    uint32_t mid = begin;
    RangeBounds left, right;
    if (best.axis >= 0 && depth < kMaxSahDepth) {
      mid = partition(begin, end, axes4, best.axis, best.bin, left, right);
      for (int i = 0; i < config_.bins; ++i) {
        RangeBounds& side = i < best.bin ? left : right;
        side.lo = _mm_min_ps(side.lo, bins.lo[best.axis][i]);
        side.hi = _mm_max_ps(side.hi, bins.hi[best.axis][i]);
      }
    }
    if (mid == begin || mid == end) {
      // All centroids coincide (or the tree is too deep): split the range in half.
      mid = begin + count / 2;
      left = range_bounds(begin, mid);
      right = range_bounds(mid, end);
    }

    const auto children = nodes_.grow_by(2);
    const uint32_t left_index = static_cast<uint32_t>(children - nodes_.begin());
    {
      BinaryNode& node = nodes_[index];
      node.bounds = bounds;
      node.count = 0;
      node.first = left_index;
      node.right = left_index + 1;
    }
    if (count >= config_.parallel_threshold) {
      group.run([this, left_index, begin, mid, depth, left, &group] {
        build_node(left_index, begin, mid, depth + 1, left, group);
      });
      build_node(left_index + 1, mid, end, depth + 1, right, group);
    } else {
      build_node(left_index, begin, mid, depth + 1, left, group);
      build_node(left_index + 1, mid, end, depth + 1, right, group);
    }
  }

  BuildConfig config_;
  int block_shift_ = -1;          // log2(block_size) when that is a power of two, else -1
  HugePageVector<PrimRef> refs_;  // left uninitialised by its allocator until the boxes come
  tbb::concurrent_vector<BinaryNode, HugePageAllocator<BinaryNode>> nodes_;
};

}  // namespace

void check_build_config(size_t count, const BuildConfig& config) {
  // Refused rather than clamped, so that a caller never silently gets a tree other than the one it
  // configured; the wide BVH would lose every lane of a leaf past the eighth.
  if (config.max_leaf_size == 0 || config.max_leaf_size > kMaxLeafSize) {
    throw std::invalid_argument("BuildConfig::max_leaf_size is " +
                                std::to_string(config.max_leaf_size) + "; it must be 1 to " +
                                std::to_string(kMaxLeafSize) +
                                " (a leaf is one eight-lane triangle block)");
  }
  if (config.block_size == 0) throw std::invalid_argument("BuildConfig::block_size must be >= 1");
  if (count > std::numeric_limits<uint32_t>::max()) {
    throw std::invalid_argument("build: " + std::to_string(count) +
                                " primitives; at most 2^32 - 1 are indexed");
  }
}

BinaryBvh build_binned_sah(size_t count, const BoxSource& boxes, const BuildConfig& config) {
  check_build_config(count, config);
  return Builder(count, boxes, config).build();
}

BinaryBvh build_binned_sah(std::span<const Bounds3> prim_bounds, const BuildConfig& config) {
  return build_binned_sah(
      prim_bounds.size(),
      [&](size_t begin, size_t end, Bounds3* out) {
        std::copy(prim_bounds.begin() + static_cast<std::ptrdiff_t>(begin),
                  prim_bounds.begin() + static_cast<std::ptrdiff_t>(end), out);
      },
      config);
}

}  // namespace tritrace::bvh
