// Binned SAH construction. Each task splits one node's range of the primitive permutation: it bins
// centroids along all three axes, sweeps the bins for the cheapest plane, partitions in place and
// recurses, spawning a task for large halves. Nodes go into a concurrent vector; a node's index is
// reserved before its children are built, so the tree needs no fix-up pass. SAH costs are computed
// in double where float's would overflow (box areas beyond about 1e19); bin indices are clamped in
// float before the cast to int, which is undefined for inf and NaN.
#include "tritrace/accel/bvh/binned_sah_builder.h"

#include <tbb/blocked_range.h>
#include <tbb/concurrent_vector.h>

#include <algorithm>
#include <array>
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

// Bounds3::centre(), except where lo + hi overflows float (bounds beyond about 1.7e38): there the
// halves are summed instead, which cannot overflow. (Halving first everywhere would round
// denormal centroids.)
glm::vec3 centroid_of(const Bounds3& b) {
  glm::vec3 c = b.centre();
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(c[a])) c[a] = b.lo[a] * 0.5f + b.hi[a] * 0.5f;
  }
  return c;
}

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

struct BinSet {
  std::array<std::array<Bin, kMaxBins>, 3> axis;
  Bounds3 bounds = Bounds3::empty();  // of the primitives, not only their centroids
};

class Builder {
 public:
  Builder(std::span<const Bounds3> prim_bounds, const BuildConfig& config)
      : bounds_(prim_bounds), config_(config) {
    config_.bins = std::clamp(config_.bins, 2, kMaxBins);
    centroids_.resize(prim_bounds.size());
    parallel::for_range(tbb::blocked_range<size_t>(0, prim_bounds.size()), [&](const auto& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) centroids_[i] = centroid_of(prim_bounds[i]);
    });
  }

  BinaryBvh build() {
    BinaryBvh out;
    const uint32_t n = static_cast<uint32_t>(bounds_.size());
    if (n == 0) return out;
    prims_.resize(n);
    std::iota(prims_.begin(), prims_.end(), 0u);
    nodes_.reserve(2 * (n / std::max(1u, config_.max_leaf_size / 2)) + 1);
    const uint32_t root = static_cast<uint32_t>(nodes_.grow_by(1) - nodes_.begin());
    parallel::TaskGroup group;
    build_node(root, 0, n, 0, group);
    group.wait();
    out.nodes.assign(nodes_.begin(), nodes_.end());
    out.prim_index = std::move(prims_);
    return out;
  }

 private:
  template <typename Real = double>
  Real leaf_cost(uint32_t count) const {
    const uint32_t blocks = (count + config_.block_size - 1) / config_.block_size;  // rounded up
    return static_cast<Real>(config_.block_cost) * static_cast<Real>(blocks);
  }

  // Centroid bounds and primitive bounds of a range.
  std::pair<Bounds3, Bounds3> range_bounds(uint32_t begin, uint32_t end) const {
    using Pair = std::pair<Bounds3, Bounds3>;
    auto body = [&](const tbb::blocked_range<uint32_t>& r, Pair acc) {
      for (uint32_t i = r.begin(); i != r.end(); ++i) {
        acc.first.extend(centroids_[prims_[i]]);
        acc.second.extend(bounds_[prims_[i]]);
      }
      return acc;
    };
    const Pair init{Bounds3::empty(), Bounds3::empty()};
    if (end - begin < config_.parallel_threshold) {
      return body(tbb::blocked_range<uint32_t>(begin, end), init);
    }
    return parallel::reduce(tbb::blocked_range<uint32_t>(begin, end, 4096), init, body,
                            [](Pair a, const Pair& b) {
                              a.first.extend(b.first);
                              a.second.extend(b.second);
                              return a;
                            });
  }

  BinSet bin_range(uint32_t begin, uint32_t end, const std::array<AxisBins, 3>& axes) const {
    auto body = [&](const tbb::blocked_range<uint32_t>& r, BinSet acc) {
      for (uint32_t i = r.begin(); i != r.end(); ++i) {
        const uint32_t p = prims_[i];
        for (int a = 0; a < 3; ++a) {
          Bin& bin = acc.axis[a][axes[a].bin_of(centroids_[p][a])];
          bin.bounds.extend(bounds_[p]);
          ++bin.count;
        }
      }
      return acc;
    };
    if (end - begin < config_.parallel_threshold) {
      return body(tbb::blocked_range<uint32_t>(begin, end), BinSet{});
    }
    return parallel::reduce(tbb::blocked_range<uint32_t>(begin, end, 4096), BinSet{}, body,
                            [&](BinSet a, const BinSet& b) {
                              for (int ax = 0; ax < 3; ++ax) {
                                for (int i = 0; i < config_.bins; ++i) {
                                  a.axis[ax][i].bounds.extend(b.axis[ax][i].bounds);
                                  a.axis[ax][i].count += b.axis[ax][i].count;
                                }
                              }
                              return a;
                            });
  }

  // The cheapest split of `count` primitives binned in `bins`, with costs computed in Real.
  template <typename Real>
  Split best_split(const BinSet& bins, const std::array<AxisBins, 3>& axes, uint32_t count) const {
    Split best;
    Real best_cost = std::numeric_limits<Real>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (!axes[a].splittable) continue;
      std::array<Real, kMaxBins> right_cost{};
      Bounds3 acc = Bounds3::empty();
      uint32_t n = 0;
      for (int i = config_.bins - 1; i > 0; --i) {
        acc.extend(bins.axis[a][i].bounds);
        n += bins.axis[a][i].count;
        right_cost[i] = n > 0 ? area_as<Real>(acc) * leaf_cost<Real>(n) : Real{0};
      }
      acc = Bounds3::empty();
      n = 0;
      for (int i = 0; i < config_.bins - 1; ++i) {
        acc.extend(bins.axis[a][i].bounds);
        n += bins.axis[a][i].count;
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

  void build_node(uint32_t index, uint32_t begin, uint32_t end, uint32_t depth,
                  parallel::TaskGroup& group) {
    const uint32_t count = end - begin;
    // Not a structured binding: the lambda below captures `bounds`, which clang 14 refuses for one.
    const std::pair<Bounds3, Bounds3> ranges = range_bounds(begin, end);
    const Bounds3& cb = ranges.first;
    const Bounds3& bounds = ranges.second;

    auto make_leaf = [&] {
      BinaryNode& node = nodes_[index];
      node.bounds = bounds;
      node.first = begin;
      node.count = count;
    };

    // Find the cheapest binned split over the three axes.
    std::array<AxisBins, 3> axes;
    for (int a = 0; a < 3; ++a) axes[a] = AxisBins(cb.lo[a], cb.hi[a], config_.bins);
    const double parent_area = area_as<double>(bounds);
    Split best;
    if (count > 1) {
      const BinSet bins = bin_range(begin, end, axes);
      // Float is enough, and measured about 3% faster over a terrain:1m build, wherever no cost
      // can overflow: every box swept lies inside the node's, so a cost is below twice its area
      // times the cost of a leaf of all its primitives.
      const double largest_cost = 2.0 * parent_area * leaf_cost(count);
      best = largest_cost < 0.25 * std::numeric_limits<float>::max()
                 ? best_split<float>(bins, axes, count)
                 : best_split<double>(bins, axes, count);
    }
    const double best_cost = best.cost;
    const int best_axis = best.axis, best_split = best.bin;

    if (count <= config_.max_leaf_size) {
      const double split_cost =
          config_.traversal_cost + (parent_area > 0.0 ? best_cost / parent_area : 0.0);
      // Written so that a NaN cost (only from boxes outside the input contract) makes a leaf.
      if (best_axis < 0 || !(leaf_cost(count) > split_cost)) return make_leaf();
    }

    uint32_t mid;
    if (best_axis >= 0 && depth < kMaxSahDepth) {
      const AxisBins& axis = axes[best_axis];
      const int a = best_axis;
      const auto it = std::partition(prims_.begin() + begin, prims_.begin() + end, [&](uint32_t p) {
        return axis.bin_of(centroids_[p][a]) < best_split;
      });
      mid = static_cast<uint32_t>(it - prims_.begin());
    } else {
      // All centroids coincide (or the tree is too deep): split the range in half.
      mid = begin + count / 2;
    }
    if (mid == begin || mid == end) mid = begin + count / 2;

    const auto children = nodes_.grow_by(2);
    const uint32_t left = static_cast<uint32_t>(children - nodes_.begin());
    {
      BinaryNode& node = nodes_[index];
      node.bounds = bounds;
      node.count = 0;
      node.first = left;
      node.right = left + 1;
    }
    if (count >= config_.parallel_threshold) {
      group.run([this, left, begin, mid, depth, &group] {
        build_node(left, begin, mid, depth + 1, group);
      });
      build_node(left + 1, mid, end, depth + 1, group);
    } else {
      build_node(left, begin, mid, depth + 1, group);
      build_node(left + 1, mid, end, depth + 1, group);
    }
  }

  std::span<const Bounds3> bounds_;
  BuildConfig config_;
  std::vector<glm::vec3> centroids_;
  std::vector<uint32_t> prims_;
  tbb::concurrent_vector<BinaryNode> nodes_;
};

}  // namespace

BinaryBvh build_binned_sah(std::span<const Bounds3> prim_bounds, const BuildConfig& config) {
  // Refused rather than clamped, so that a caller never silently gets a tree other than the one it
  // configured; the wide BVH would lose every lane of a leaf past the eighth.
  if (config.max_leaf_size == 0 || config.max_leaf_size > kMaxLeafSize) {
    throw std::invalid_argument("BuildConfig::max_leaf_size is " +
                                std::to_string(config.max_leaf_size) + "; it must be 1 to " +
                                std::to_string(kMaxLeafSize) +
                                " (a leaf is one eight-lane triangle block)");
  }
  if (config.block_size == 0) throw std::invalid_argument("BuildConfig::block_size must be >= 1");
  return Builder(prim_bounds, config).build();
}

}  // namespace tritrace::bvh
