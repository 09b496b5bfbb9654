// Every triangle a ray crosses, through the wide BVH: the count and the list of crossings of each
// ray of a batch within its [tmin, tmax]. A crossing through an edge or a vertex shared by several
// triangles is counted exactly once (geometry/crossing.h gives the rule), so counts along a line
// through a closed mesh are even and their parity from a point says inside or outside.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/hit.h"
#include "tritrace/math/ray.h"

namespace tritrace::bvh {

// The crossings of a batch of rays: ray i's are hits[ray_splits[i]] up to hits[ray_splits[i + 1]],
// sorted by t, exact ties by prim.
struct Intersections {
  std::vector<uint64_t> ray_splits;  // rays + 1 entries, the first 0
  std::vector<Hit> hits;
};

// How many triangles each ray crosses within [tmin, tmax]. A ray with a non-finite origin or
// direction, a zero direction or tmin > tmax crosses nothing. Reads the tree's triangle blocks
// only (their exact vertices), so it works on any tree build_wide_bvh made, whatever accel's
// kernel.
void count_intersections(const WideBvh& tree, std::span<const Ray> rays,
                         std::span<uint32_t> counts);
// The crossings themselves: `out` is overwritten.
void list_intersections(const WideBvh& tree, std::span<const Ray> rays, Intersections& out);

// One ray: the count, and its crossings appended to `out` in the order above.
uint32_t count_crossings(const WideBvh& tree, const Ray& ray);
void list_crossings(const WideBvh& tree, const Ray& ray, std::vector<Hit>& out);

}  // namespace tritrace::bvh
