// LabIntegrator: the lab's shading, colour = albedo * (direct + indirect), with direct light from
// each point light, P * max(n.r, 0) / (4 pi |r|^2), blocked by a shadow ray, and a constant
// indirect term (the scene's ambient). A missed ray is black.
#pragma once

#include "tritrace/render/integrator.h"

namespace tritrace {

// The shadow ray starts this far from the hit point, toward the light, so that it cannot hit the
// surface it starts on (as the lab solutions do; see ../shared/lab-cornell-box.md).
inline constexpr float kLabShadowOffset = 1e-3f;

class LabIntegrator final : public Integrator {
 public:
  uint64_t radiance(std::span<const Ray> rays, std::span<glm::vec3> radiance, const Scene& scene,
                    const Accel& accel) const override;
};

}  // namespace tritrace
