// AlphaTestedAccel: cut-outs and stochastic transparency (glTF's alpha MASK and BLEND) for any
// Accel. It wraps the scene's structure and skips the hits that a material's alpha says are
// transparent, by tracing again from just beyond them; make_accel wraps only scenes that have such
// materials, so opaque scenes trace exactly as before.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "tritrace/accel/accel.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// The number in [0, 1) that decides whether `ray` passes a blended triangle `prim`: a hash of the
// ray's origin and direction bits and the triangle, so that it is the same whatever thread or tile
// traces the ray, and as good as uniform over the many rays of a render (the ray passes where it
// is >= alpha: with probability 1 - alpha).
float blend_threshold(const Ray& ray, uint32_t prim);

class AlphaTestedAccel final : public Accel {
 public:
  // `inner` is the structure over `scene` (which must outlive this).
  AlphaTestedAccel(const Scene& scene, std::unique_ptr<Accel> inner);

  // The closest hit whose surface is not transparent where the ray meets it: while the closest hit
  // is transparent (kMask: alpha < cutoff; kBlend: alpha <= blend_threshold), the ray is traced
  // again over [next float above its t, tmax], with its origin and direction unchanged so that
  // every triangle's t comes out bit for bit the same and none is met twice. Two triangles at
  // exactly the same t are one point of the surface, which (by Accel's tie rule) the first of them
  // stands for: when that one is transparent there, so is the point.
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  // 1 when a hit that is not transparent lies in [tmin, tmax].
  void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;
  void intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded_incoherent(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;

  // Whether `hit` (found by `ray`) is on a transparent part of its surface.
  bool transparent(const Ray& ray, const Hit& hit) const;

  const Accel& inner() const { return *inner_; }

 private:
  // Traces again, from beyond their transparent hits, the rays of `rays` whose `hits` are
  // transparent, until each hit is opaque or none.
  void skip_transparent(std::span<const Ray> rays, std::span<Hit> hits) const;
  void resolve_occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const;

  const Scene& scene_;
  std::unique_ptr<Accel> inner_;
  std::vector<uint8_t> tested_;  // per material: alpha_tested
};

}  // namespace tritrace
