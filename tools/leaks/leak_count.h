// The closed-mesh leak test: rays aimed exactly at the shared edges and vertices of a closed,
// convex mesh, from inside and from outside, and a count of those that pass through the surface
// without a hit, for a kernel alone and through the accels the CLI builds. A watertight kernel lets
// none through (Woop, Benthin, Wald 2013); an accel must not lose what its kernel catches.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "leaks/closed_meshes.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/geometry/intersect.h"
#include "tritrace/math/ray.h"

namespace tritrace::leaks {

struct LeakCounts {
  uint64_t rays = 0;
  uint64_t leaks = 0;
  uint64_t inside_rays = 0, inside_leaks = 0;    // origin inside: any hit is the exit
  uint64_t outside_rays = 0, outside_leaks = 0;  // origin outside: the first hit must be the entry
  uint64_t vertex_rays = 0, vertex_leaks = 0;    // aimed at a vertex (the rest at edge points)
  // Through an instance only: outside rays that missed the whole mesh, not counted as leaks
  // (run_chunk in leak_count.cpp says why).
  uint64_t grazing_misses = 0;

  LeakCounts& operator+=(const LeakCounts& o);
  bool operator==(const LeakCounts&) const = default;
  double percent() const { return rays ? 100.0 * static_cast<double>(leaks) / rays : 0.0; }
};

struct LeakOptions {
  uint64_t rays = 100'000;  // per mesh
  uint64_t seed = 1;
  // Test each ray against every triangle of the mesh rather than only those around the aimed-at
  // edge or vertex, when the kernel is called alone. Slower, the same answer on a closed convex
  // mesh (tested); for checking that.
  bool all_triangles = false;
};

// Rays per coherent bundle: one packet of the BVH's AVX-512 traversal (two with AVX2).
inline constexpr int kBundleSize = 16;

// Where the aimed rays go. Without an accel, the kernel is called on the triangles around the
// target (or all of them: LeakOptions::all_triangles). With one, make_accel builds it over the
// whole mesh with the run's kernel, as the CLI does, and its closest hit is judged, so the accel
// takes whatever path it takes for that kernel (BvhAccel: packets only where the kernel has a
// packet version). Scattered rays reach an accel as one batch per 4096 rays, so BvhAccel's packets
// hold unrelated rays (on a fine mesh each reaches its own leaves: the few-ray leaf path); bundles
// reach it as one batch of kBundleSize coherent rays at a time (nearby origins, aimed at one vertex
// or at points along a short stretch of one edge), which BvhAccel traces as one packet whose rays
// reach the same leaves together.
// With `instance`, the accel is built over a scene that places the mesh once, as an instance
// moved by that transform (make_accel's two-level structure), and each aimed ray is moved to world
// space by it (direction not renormalised, so the aim's t stays valid); the traversal moves it
// back into object space, with rounding, before the kernel sees it.
struct LeakPath {
  std::optional<AccelKind> accel;
  bool bundles = false;
  std::optional<Affine> instance = std::nullopt;
};

// "kernel", or the accel's name ("brute", "bvh-single", "bvh"), plus " bundles" for bundles and
// " instanced" for an instance.
std::string leak_path_name(const LeakPath& path);

// The report's rows: the kernel alone, then brute, bvh-single and bvh on the same scattered rays,
// then bvh on bundles.
std::vector<LeakPath> report_paths();

struct LeakRun {
  LeakPath path;
  Kernel kernel = Kernel::kWatertight;
  uint64_t rays = 0;  // 0: LeakOptions::rays
};

// How it aims: half of the rays at a vertex, half at a point a + s (b - a) of an edge, computed in
// float (so on the edge up to rounding). Half start inside: at c + f (p - c), c the mean of the
// vertices, p a random vertex, f in [0, 0.9], inside because the meshes are convex. Half start
// outside, at the target plus 2 bounding radii along a direction making at least 5.7 degrees
// (dot >= 0.1) with every face at the target, so the ray truly crosses the surface there. A
// bundle shares its side, its target vertex or edge and a base origin (inside) or direction
// (outside). Its edge points are spread evenly over a stretch of at most a quarter of the edge
// and 0.2 of the edge's distance from the origin. Inside, each ray's origin moves from the base
// towards another point c + f (p' - c) (so it stays inside) by at most 5% of the way and 0.1 of
// that distance; outside, each ray's direction is the base one turned by up to about 3 degrees,
// still 5.7 degrees off every face.
//
// A ray leaks when, from inside, it hits none of the triangles around the target (through an
// accel: nothing at all, as with all_triangles), or, from outside, its closest hit is not at the
// target (none, or one farther than 1e-5 relative, 1e-3 through an instance: it went in without
// touching the surface and only hit the far side). Rays depend only on the seed, so they are the
// same for every kernel and path (scattered and bundled rays are two sets), and the count is the
// same for any thread count.
LeakCounts count_leaks(const IndexedMesh& mesh, Kernel kernel, const LeakOptions& options);
LeakCounts count_leaks(const IndexedMesh& mesh, const LeakPath& path, Kernel kernel,
                       const LeakOptions& options);

// Several runs on one mesh. Each chunk of rays is made once and goes through every run (a run with
// fewer rays gets the first of them): making the rays costs more than tracing them on small meshes.
std::vector<LeakCounts> count_leaks(const IndexedMesh& mesh, std::span<const LeakRun> runs,
                                    const LeakOptions& options);

// The first `count` rays that the count aims at `mesh`, scattered or in bundles of kBundleSize
// consecutive rays; for tests.
std::vector<Ray> aimed_rays(const IndexedMesh& mesh, bool bundles, uint64_t count, uint64_t seed);

}  // namespace tritrace::leaks
