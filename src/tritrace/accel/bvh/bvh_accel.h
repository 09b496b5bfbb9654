// BvhAccel: tritrace's own acceleration structure, an eight-wide BVH with SIMD triangle blocks in
// the leaves, traversed nearest child first either one ray at a time (AVX2 box tests over the eight
// children) or in packets of coherent rays (packet_traversal.h). With the same kernel it returns
// exactly the hits of BruteForceAccel, ties included.
#pragma once

#include <atomic>
#include <cstdint>

#include "tritrace/accel/accel.h"
#include "tritrace/accel/bvh/convex_groups.h"
#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/intersect.h"

namespace tritrace {

enum class BvhTraversal {
  kAuto,    // packets of coherent rays where the kernel has a packet version, else single rays
  kSingle,  // one ray at a time
  // One ray at a time, and the incoherent queries' rays interleaved (several in flight, see
  // bvh_accel.cpp) whatever the tree's size, where the others interleave on big trees only. For
  // tests: the answers are the same either way.
  kSingleInterleaved,
};

class BvhAccel final : public Accel {
 public:
  // Keeps a reference to `mesh`, which must outlive the accel (the scalar kernels read its
  // vertices).
  BvhAccel(const TriangleMesh& mesh, Kernel kernel, const bvh::BuildConfig& config = {},
           BvhTraversal traversal = BvhTraversal::kAuto);
  // Over a tree that build_wide_bvh made from `mesh`, for a caller that adjusts its triangle
  // blocks first (GeometrySet keeps zero-area triangles out of every hit that way).
  BvhAccel(const TriangleMesh& mesh, bvh::WideBvh tree, Kernel kernel,
           BvhTraversal traversal = BvhTraversal::kAuto);

  using Accel::intersect;
  using Accel::occluded;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;
  // Single-ray traversal whatever the traversal setting, except on a tree small enough to stay in
  // L1 under kAuto, whose incoherent rays go as packets too (the same answers).
  void intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;
  // With the triangles the rays leave: a small mesh's single rays (those not traced as packets or
  // interleaved) skip the subtrees holding only the convex group they leave outwards
  // (bvh/convex_groups.h, computed at build for meshes with a second tree).
  void intersect_incoherent_from(std::span<const Ray> rays, std::span<const uint32_t> origins,
                                 std::span<Hit> hits) const override;
  void occluded_incoherent_from(std::span<const Ray> rays, std::span<const uint32_t> origins,
                                std::span<uint8_t> occluded) const override;
  // The convex groups of the mesh (none for a mesh without a second tree).
  const bvh::ConvexGroups& convex_groups() const { return convex_; }

  const bvh::WideBvh& tree() const { return bvh_; }
  // The tree of intersect_incoherent: tree() itself, or for a small mesh built with fine leaves a
  // second tree with bigger ones (bvh::incoherent_closest_config), on which single rays and
  // incoherent packets take fewer steps to their closest hit.
  const bvh::WideBvh& closest_tree() const { return closest_.nodes.empty() ? bvh_ : closest_; }
  // The tree of occluded_incoherent, and whether its rays go as packets there: tree() one ray at a
  // time, or closest_tree() where that is a second tree, or packets of kPacketSize rays through
  // either, whichever way the rays given to occluded_incoherent take the least work. One call in
  // kOccludedProbeEvery (per thread) is traced one ray at a time through both trees, and one such
  // call in kPacketProbeEvery as packets through both too, its node and leaf visits counted and
  // priced as the SAH prices them (a packet's test of one child box at kPacketBoxPrice of a
  // node visit, a block tested for one ray or a triangle for the whole packet as a block visit),
  // and once kOccludedProbeRays rays have been counted each count chooses again from all counted
  // so far: a frame's first tiles alone, whose rays may be unlike the rest (sky or ground), do not
  // decide. tree() one ray at a time until then. The answers are the same every way.
  static constexpr uint64_t kOccludedProbeEvery = 128;
  static constexpr uint64_t kOccludedProbeRays = 2048;
  // A packet's box test took 13-18 ns, a single ray's node or block visit about 20 ns, on
  // glass.json's and sky.json's shadow rays (docs/PERFORMANCE.md, issue 27): those scenes' counts
  // pick their faster way for any price from 0.5 to 1.4.
  static constexpr double kPacketBoxPrice = 0.75;
  static constexpr uint64_t kPacketProbeEvery = 4;  // of the probed calls, those that try packets
  const bvh::WideBvh& occluded_tree() const {
    return (occluded_choice_.load(std::memory_order_relaxed) & kCoarse) ? closest_ : bvh_;
  }
  bool occluded_as_packets() const {
    return (occluded_choice_.load(std::memory_order_relaxed) & kPackets) != 0;
  }
  Kernel kernel() const { return kernel_; }

 private:
  const TriangleMesh& mesh_;
  bvh::WideBvh bvh_;
  Kernel kernel_;
  bool packets_;
  bool incoherent_packets_ = false;  // intersect_incoherent as packets: packets_ on a tiny tree
  [[maybe_unused]] bool interleave_ = false;  // incoherent rays several at a time (AVX2 builds)
  bvh::WideBvh closest_;                      // empty, or closest_tree()'s own
  // incoherent_packets_ and interleave_ for closest_tree()
  bool closest_packets_ = false;
  [[maybe_unused]] bool closest_interleave_ = false;
  // occluded_tree()'s and occluded_as_packets()' choice (a kCoarse bit and a kPackets bit) and the
  // probe that makes it: node and leaf-block visits of the probed rays through each tree ([0]
  // tree(), [1] closest_tree()) one at a time, and box tests and leaf work as packets, and the
  // SAH's prices.
  enum : int { kFine = 0, kCoarse = 1, kPackets = 2 };
  mutable std::atomic<int> occluded_choice_{kFine};
  bool probes_occluded_ = false;  // a second tree and single shadow rays: the choice is counted
  bool probes_packets_ = false;   // packets are among the ways counted
  mutable std::atomic<uint64_t> probe_rays_{0};
  mutable std::atomic<uint64_t> probe_nodes_[2] = {0, 0}, probe_blocks_[2] = {0, 0};
  mutable std::atomic<uint64_t> probe_box_tests_[2] = {0, 0}, probe_leaf_tests_[2] = {0, 0};
  float node_price_ = 1.0f, block_price_ = 1.0f;
  // The mesh's convex groups and, per tree, the group below each node's children.
  bvh::ConvexGroups convex_;
  std::vector<bvh::ChildGroups> fine_groups_, closest_groups_;
  bool skips(std::span<const uint32_t> origins, size_t rays) const {
    return convex_.count() > 0 && origins.size() == rays;
  }

  void probe_occluded(std::span<const Ray> rays, std::span<const uint32_t> origins,
                      std::span<uint8_t> occluded) const;
};

}  // namespace tritrace
