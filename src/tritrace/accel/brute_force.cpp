// The brute-force loops, instantiated once per kernel so the kernel inlines into the loop.
#include "tritrace/accel/brute_force.h"

namespace tritrace {
namespace {

template <Kernel K>
void intersect_all(const TriangleMesh& mesh, std::span<const Ray> rays, std::span<Hit> hits) {
  const TriangleArrays tris = mesh.arrays();
  const uint32_t n = static_cast<uint32_t>(mesh.size());
  for (size_t r = 0; r < rays.size(); ++r) {
    const PreparedRay<K> ray(rays[r]);
    Hit best;
    TriangleHit h;
    for (uint32_t i = 0; i < n; ++i) {
      // Strictly closer: on an exact tie the earlier triangle keeps the hit.
      if (ray.intersect(tris, i, h) && h.t < best.t) {
        best = {h.t, h.u, h.v, i};
      }
    }
    hits[r] = best;
  }
}

template <Kernel K>
void occluded_all(const TriangleMesh& mesh, std::span<const Ray> rays,
                  std::span<uint8_t> occluded) {
  const TriangleArrays tris = mesh.arrays();
  const uint32_t n = static_cast<uint32_t>(mesh.size());
  for (size_t r = 0; r < rays.size(); ++r) {
    const PreparedRay<K> ray(rays[r]);
    uint8_t blocked = 0;
    TriangleHit h;
    for (uint32_t i = 0; i < n; ++i) {
      if (ray.intersect(tris, i, h)) {
        blocked = 1;
        break;
      }
    }
    occluded[r] = blocked;
  }
}

}  // namespace

BruteForceAccel::BruteForceAccel(const TriangleMesh& mesh, Kernel kernel)
    : mesh_(mesh), kernel_(kernel) {}

void BruteForceAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  with_kernel(kernel_, [&]<Kernel K>() { intersect_all<K>(mesh_, rays, hits); });
}

void BruteForceAccel::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  with_kernel(kernel_, [&]<Kernel K>() { occluded_all<K>(mesh_, rays, occluded); });
}

}  // namespace tritrace
