// The closed-mesh leak test: rays aimed exactly at the shared edges and vertices of a closed,
// convex mesh, from inside and from outside, and a count of those that pass through the surface
// without a hit. A watertight kernel lets none through (Woop, Benthin, Wald 2013).
#pragma once

#include <cstdint>

#include "leaks/closed_meshes.h"
#include "tritrace/geometry/intersect.h"

namespace tritrace::leaks {

struct LeakCounts {
  uint64_t rays = 0;
  uint64_t leaks = 0;
  uint64_t inside_rays = 0, inside_leaks = 0;    // origin inside: any hit is the exit
  uint64_t outside_rays = 0, outside_leaks = 0;  // origin outside: the first hit must be the entry
  uint64_t vertex_rays = 0, vertex_leaks = 0;    // aimed at a vertex (the rest at edge points)

  LeakCounts& operator+=(const LeakCounts& o);
  double percent() const { return rays ? 100.0 * static_cast<double>(leaks) / rays : 0.0; }
};

struct LeakOptions {
  uint64_t rays = 100'000;  // per mesh
  uint64_t seed = 1;
  // Test each ray against every triangle of the mesh rather than only those around the aimed-at
  // edge or vertex. Slower, the same answer on a closed convex mesh (tested); for checking that.
  bool all_triangles = false;
};

// How it aims: half of the rays at a vertex, half at a point a + s (b - a) of an edge, computed in
// float (so on the edge up to rounding). Half start inside: at c + f (p - c), c the mean of the
// vertices, p a random vertex, f in [0, 0.9], inside because the meshes are convex. Half start
// outside, at the target plus 2 bounding radii along a direction making at least 5.7 degrees
// (dot >= 0.1) with every face at the target, so the ray truly crosses the surface there.
//
// A ray leaks when, from inside, it hits none of the triangles around the target, or, from
// outside, its closest hit is not at the target (none, or one farther than 1e-5 relative: it went
// in without touching the surface and only hit the far side). Rays are the same for every kernel
// (same seed), and the count is the same for any thread count.
LeakCounts count_leaks(const IndexedMesh& mesh, Kernel kernel, const LeakOptions& options);

}  // namespace tritrace::leaks
