// LabIntegrator: the lab's shading, colour = albedo * (direct + indirect), with direct light from
// each point light, P * max(n.r, 0) / (4 pi |r|^2), blocked by a shadow ray, and a constant
// indirect term (the scene's ambient). A missed ray is black.
#pragma once

#include <string>

#include "tritrace/geometry/hit.h"
#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/math/offset_ray.h"
#include "tritrace/render/integrator.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// The shadow ray from a primary hit to a point light. It runs from the hit point (from the
// barycentrics), moved off its surface on the light's side by offset_ray_origin (after Wächter
// and Binder 2019), to the light moved towards it the same way, so a surface the light sits on
// does not shadow it. Unlike the lab's fixed 1e-3 along the light direction, this works at any
// scale and position, never starts the ray behind a neighbouring wall, and never lets it hit its
// own surface.
struct ShadowRay {
  enum class Kind {
    kBehind,  // the light is behind the surface (or on its plane): no direct light
    kLit,     // the light is nearer than the offsets: nothing can be in between
    kTrace,   // trace `ray`: lit when it hits nothing
  };
  Kind kind = Kind::kBehind;
  Ray ray;
  float cos_theta = 0.0f;  // between the lab normal and the direction to the light
  float dist2 = 0.0f;      // squared distance from the hit point to the light
};
ShadowRay lab_shadow_ray(const TriangleMesh& mesh, const Hit& hit, glm::vec3 light,
                         const RayOffsetParams& offset = {});
// The same for a triangle given in world space (an instanced one: Scene::triangle).
ShadowRay lab_shadow_ray(const SurfaceTriangle& tri, const Hit& hit, glm::vec3 light,
                         const RayOffsetParams& offset = {});

// lab_shadow_ray for each hit of a batch, out[i] for hits[i] (a missed ray gets a default
// ShadowRay: kBehind). Where the build has SIMD it shades simd::kLanes hits at once with the same
// IEEE operations in the same order, so every field is the same bit for bit (tested).
void lab_shadow_rays(const TriangleMesh& mesh, std::span<const Hit> hits, glm::vec3 light,
                     const RayOffsetParams& offset, std::span<ShadowRay> out);

// Why the lab integrator cannot render `scene` as its author meant (empty when it can): the lab's
// model has point lights only, so a scene with spot or directional lights is refused rather than
// drawn without them.
std::string lab_unsupported(const Scene& scene);

class LabIntegrator final : public Integrator {
 public:
  explicit LabIntegrator(const RayOffsetParams& offset = {}) : offset_(offset) {}

  // The lab's camera: one ray through each pixel's corner, no random numbers.
  bool pixel_corner_only() const override { return true; }
  uint64_t radiance(const SampleBatch& batch, const SampleOutput& out, const Scene& scene,
                    const Accel& accel) const override;

 private:
  RayOffsetParams offset_;
};

}  // namespace tritrace
