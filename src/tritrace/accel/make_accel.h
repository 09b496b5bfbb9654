// Choosing an acceleration structure by name: the one place that knows every backend, so front
// ends and benchmarks treat them alike.
#pragma once

#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "tritrace/accel/accel.h"
#include "tritrace/accel/bvh/binned_sah_builder.h"
#include "tritrace/geometry/intersect.h"
#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// kBvh and kEmbree trace coherent batches as packets (Embree: 16 rays where it has native 16-wide
// kernels, else 8); kEmbree8 always 8-wide packets; kBvhSingle and kEmbreeSingle one ray at a
// time. All for comparison: which Embree mode is fastest depends on the scene and the CPU.
// kEmbreeRobust is kEmbree with RTC_SCENE_FLAG_ROBUST (robust traversal, no optimisations that
// cost accuracy, so that rays do not slip between neighbouring triangles): the like-for-like
// comparison for tritrace's watertight kernel.
enum class AccelKind { kBvh, kBrute, kEmbree, kEmbreeSingle, kBvhSingle, kEmbree8, kEmbreeRobust };

// "bvh", "brute", "embree", "embree-single", "bvh-single", "embree8", "embree-robust"
std::string_view accel_name(AccelKind kind);
std::optional<AccelKind> parse_accel(std::string_view name);
bool accel_available(AccelKind kind);  // Embree only when built with it
std::vector<AccelKind> available_accels();
// The Embree this build links ("3.13.5"), or empty when built without it.
std::string_view embree_version();

// The kernel used when none is asked for: the watertight kernel for every accel tritrace
// implements (brute, bvh, bvh-single), so that they write byte-identical images by default. The
// rule (issue 6) is "watertight wherever it costs within 15% of Möller–Trumbore", which the BVH
// meets with its SIMD watertight leaves and packets (docs/PERFORMANCE.md). Embree uses its own
// kernel whatever is asked.
Kernel default_kernel_for(AccelKind kind);

// How bvh and bvh-single make their tree (Embree and brute force ignore it): "sah" (binned SAH,
// the tree to trace many rays through) or "morton" (faster to build on big meshes, slower to
// trace; docs/PERFORMANCE.md, "A Morton-code build").
std::string_view bvh_build_name(bvh::BuildMethod method);
std::optional<bvh::BuildMethod> parse_bvh_build(std::string_view name);

// The build that brings a render of about `rays` rays through `triangles` triangles to its end
// soonest: Morton codes where the rays are too few for the SAH tree's faster tracing to win back
// its longer build (measured in docs/PERFORMANCE.md, "A Morton-code build"), else the binned SAH.
bvh::BuildMethod bvh_build_for(size_t triangles, double rays);

struct AccelInfo {
  double build_ms = 0.0;
  size_t structure_bytes = 0;      // the structure itself, beyond the scene's triangle data
  size_t triangle_copy_bytes = 0;  // triangles the structure keeps in its own layout
};

// Builds the structure over `mesh` (which must outlive it). The kernel applies to brute and bvh;
// Embree uses its own. Throws Error(name, reason) when the backend is not built in.
std::unique_ptr<Accel> make_accel(AccelKind kind, const TriangleMesh& mesh, Kernel kernel,
                                  AccelInfo* info = nullptr,
                                  bvh::BuildMethod build = bvh::BuildMethod::kBinnedSah);

// The structure for a whole scene (which must outlive it): make_accel over scene.mesh when it has
// no instances, else an InstancedAccel with one structure of `kind` per prototype (brute: every
// instance in turn, the oracle; bvh, bvh-single: a binned SAH tree over the instances). Embree
// backends refuse instanced scenes: Error("--accel", ...). When a material of the scene is
// alpha_tested (cut-outs, stochastic transparency), that structure is wrapped in an
// AlphaTestedAccel; otherwise it is returned as it is.
std::unique_ptr<Accel> make_accel(AccelKind kind, const Scene& scene, Kernel kernel,
                                  AccelInfo* info = nullptr,
                                  bvh::BuildMethod build = bvh::BuildMethod::kBinnedSah);

}  // namespace tritrace
