// EmbreeAccel: Intel Embree 3 as a backend, to measure tritrace against the best CPU kernels on the
// same rays. Built only when CMake finds Embree (TRITRACE_WITH_EMBREE); see make_accel.h.
#pragma once

#include <cstddef>
#include <memory>

#include "tritrace/accel/accel.h"
#include "tritrace/geometry/triangle_mesh.h"

namespace tritrace {

// How batches are traced: one ray at a time (rtcIntersect1/rtcOccluded1) or as packets of 8 or 16
// consecutive rays of the batch (rtcIntersect8/16, rtcOccluded8/16), which the renderer's tiles
// make coherent.
enum class EmbreeMode { kSingle, kPacket8, kPacket16 };

class EmbreeAccel final : public Accel {
 public:
  // Builds with RTC_BUILD_QUALITY_HIGH on all cores. `robust` sets RTC_SCENE_FLAG_ROBUST: in
  // Embree's words, structures that allow robust traversal and no optimisations that reduce
  // arithmetic accuracy, against rays shooting through the edges of neighbouring primitives.
  // Throws Error when Embree fails.
  EmbreeAccel(const TriangleMesh& mesh, EmbreeMode mode, bool robust = false);
  ~EmbreeAccel() override;
  EmbreeAccel(const EmbreeAccel&) = delete;
  EmbreeAccel& operator=(const EmbreeAccel&) = delete;

  using Accel::intersect;
  using Accel::occluded;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;
  // Rays that share nothing (a path tracer's bounces and shadow rays) go one at a time
  // (rtcIntersect1/rtcOccluded1) in every mode, with RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, as
  // embree-single would trace them: packets of unrelated rays only cost their masking.
  void intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;

  EmbreeMode mode() const { return mode_; }
  bool robust() const { return robust_; }
  // Bytes Embree allocated for its acceleration structure, not counting the vertex and index
  // buffers it was given.
  size_t structure_bytes() const { return structure_bytes_; }
  // Whether this Embree build has native 16-wide (AVX-512) packet kernels.
  static bool native_packet16();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  EmbreeMode mode_;
  bool robust_;
  size_t structure_bytes_ = 0;
};

}  // namespace tritrace
