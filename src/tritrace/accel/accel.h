// Accel: the interface every acceleration structure implements. Queries come in batches (a tile's
// rays at a time), so the virtual call happens once per batch, never per ray or per triangle.
#pragma once

#include <cstdint>
#include <span>

#include "tritrace/geometry/hit.h"
#include "tritrace/math/ray.h"

namespace tritrace {

class Accel {
 public:
  virtual ~Accel() = default;

  // For each ray, the closest hit with t in [tmin, tmax]; on an exact tie in t the triangle that
  // comes first in the scene wins. hits.size() == rays.size().
  virtual void intersect(std::span<const Ray> rays, std::span<Hit> hits) const = 0;

  // For each ray, 1 when any triangle is hit with t in [tmin, tmax], else 0.
  virtual void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const = 0;

  // The same queries for rays that share nothing (a path tracer's bounce and shadow rays): an
  // accel that traces coherent batches as packets traces these one by one instead. By default
  // the batch queries above. Same answers, bit for bit.
  virtual void intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const {
    intersect(rays, hits);
  }
  virtual void occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
    this->occluded(rays, occluded);
  }

  // The same with the triangle each ray leaves: origins[i] is ray i's origin triangle (a prim id of
  // this accel's hits), or kNoHit. An accel may use it to skip geometry the ray provably cannot
  // hit (BvhAccel: the rest of a convex mesh the ray leaves outwards, see bvh/convex_groups.h);
  // the answers differ from the queries above at most by hits on that mesh within rounding
  // distance of the origin (self-intersections). By default the queries above, origins ignored.
  virtual void intersect_incoherent_from(std::span<const Ray> rays,
                                         std::span<const uint32_t> /*origins*/,
                                         std::span<Hit> hits) const {
    intersect_incoherent(rays, hits);
  }
  virtual void occluded_incoherent_from(std::span<const Ray> rays,
                                        std::span<const uint32_t> /*origins*/,
                                        std::span<uint8_t> occluded) const {
    occluded_incoherent(rays, occluded);
  }

  // Single-ray conveniences for tests and tools.
  Hit intersect(const Ray& ray) const {
    Hit hit;
    intersect(std::span<const Ray>(&ray, 1), std::span<Hit>(&hit, 1));
    return hit;
  }
  bool occluded(const Ray& ray) const {
    uint8_t result = 0;
    occluded(std::span<const Ray>(&ray, 1), std::span<uint8_t>(&result, 1));
    return result != 0;
  }
};

}  // namespace tritrace
