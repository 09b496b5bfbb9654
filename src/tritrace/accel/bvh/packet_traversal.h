// Packet traversal of the wide BVH: kPacketSize rays at a time, one SIMD lane per ray, for the
// coherent batches a renderer's tiles produce (Wald, Slusallek, Benthin, Wagner, "Interactive
// Rendering with Coherent Ray Tracing", 2001). Leaves run the watertight kernel or
// Möller–Trumbore on all rays of the packet at once, lane for lane the same operations as the
// scalar kernel, so the hits are bit-identical to single-ray traversal and to brute force.
#pragma once

#include <cstdint>
#include <span>

#include "tritrace/accel/bvh/wide_bvh.h"
#include "tritrace/geometry/hit.h"
#include "tritrace/geometry/intersect.h"
#include "tritrace/math/simd_lanes.h"

namespace tritrace::bvh {

// 16 with AVX-512, 8 with AVX2, 0 (no packet path) otherwise.
inline constexpr int kPacketSize = simd::kLanes;

// Whether `kernel` has a packet version here: the watertight kernel and Möller–Trumbore, with AVX2
// or AVX-512.
inline bool has_packet_kernel(Kernel kernel) {
  return kPacketSize > 0 && (kernel == Kernel::kMollerTrumbore || kernel == Kernel::kWatertight);
}

// rays.size() <= kPacketSize, has_packet_kernel(kernel). Closest hits, ties to the earlier
// triangle.
void intersect_packet(const WideBvh& tree, Kernel kernel, std::span<const Ray> rays,
                      std::span<Hit> hits);
// 1 where any triangle is hit within the ray's interval.
void occluded_packet(const WideBvh& tree, Kernel kernel, std::span<const Ray> rays,
                     std::span<uint8_t> occluded);

// The work of occluded_packet: box tests (one child box against the packet's rays), leaf blocks
// tested one ray at a time (one per ray), and triangles tested against the whole packet at once.
struct PacketSteps {
  uint64_t box_tests = 0, lane_blocks = 0, packet_triangles = 0;
};
// occluded_packet, the same answers, with its work added to *steps.
void occluded_packet_counted(const WideBvh& tree, Kernel kernel, std::span<const Ray> rays,
                             std::span<uint8_t> occluded, PacketSteps* steps);

}  // namespace tritrace::bvh
