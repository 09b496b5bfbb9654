// BvhAccel: tritrace's own acceleration structure, an eight-wide BVH traversed one ray at a time
// with AVX2 box tests, nearest child first, and SIMD triangle blocks in the leaves. With the same
// kernel it returns exactly the hits of BruteForceAccel, ties included.
#pragma once

#include "tritrace/accel/accel.h"
#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/intersect.h"

namespace tritrace {

class BvhAccel final : public Accel {
 public:
  BvhAccel(const TriangleMesh& mesh, Kernel kernel, const bvh::BuildConfig& config = {});

  using Accel::intersect;
  using Accel::occluded;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;

  const bvh::WideBvh& tree() const { return bvh_; }
  Kernel kernel() const { return kernel_; }

 private:
  bvh::WideBvh bvh_;
  Kernel kernel_;
};

}  // namespace tritrace
