// A binary BVH from Morton codes (a linear BVH): primitives sorted along a Z-order curve through
// their box centres and split top-down where the codes of a range first differ, after Lauterbach
// et al., "Fast BVH Construction on GPUs" (Eurographics 2009) and Karras, "Maximizing Parallelism
// in the Construction of BVHs, Octrees, and k-d Trees" (HPG 2012). It builds faster than the
// binned SAH (binned_sah_builder.h) and traces more slowly (docs/PERFORMANCE.md, "A Morton-code
// build"): the tree for a render that traces few rays per triangle, where the build is most of the
// time to the first pixel.
#pragma once

#include <cstddef>

#include "tritrace/accel/bvh/binned_sah_builder.h"

namespace tritrace::bvh {

// The tree over `count` primitives whose boxes come from `boxes`: leaves of exactly
// config.max_leaf_size primitives consecutive along the curve (the last may hold fewer), every
// node's box the union of its primitives' boxes, children after their parent in `nodes` (as
// build_binned_sah makes them, so that collapse_binary_bvh takes either). Primitives whose centres
// share a Morton cell (10 bits per axis) stay in their index order. Nodes are numbered depth
// first (a left subtree before its right), so the array is the same whatever the thread count.
// Throws std::invalid_argument as build_binned_sah does for a bad max_leaf_size or count.
[[nodiscard]] BinaryBvh build_morton(size_t count, const BoxSource& boxes,
                                     const BuildConfig& config = {});

}  // namespace tritrace::bvh
