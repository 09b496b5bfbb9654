// BruteForceAccel: the lab's loop, every ray against every triangle, with the chosen kernel. It is
// the oracle that every faster structure is tested against.
#pragma once

#include "tritrace/accel/accel.h"
#include "tritrace/geometry/intersect.h"
#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace {

class BruteForceAccel final : public Accel {
 public:
  // Keeps a reference to `mesh`, which must outlive the accel.
  BruteForceAccel(const TriangleMesh& mesh, Kernel kernel);

  using Accel::intersect;
  using Accel::occluded;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;

  Kernel kernel() const { return kernel_; }

 private:
  const TriangleMesh& mesh_;
  Kernel kernel_;
};

}  // namespace tritrace
