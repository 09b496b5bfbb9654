// Integrator: turns a batch of primary rays into radiance. A batch is at most kMaxBatch rays (one
// tile), so integrators keep their working memory on the stack and never allocate while rendering.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <span>

#include "tritrace/accel/accel.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

inline constexpr size_t kMaxBatch = 256;

class Integrator {
 public:
  virtual ~Integrator() = default;

  // radiance.size() == rays.size() <= kMaxBatch. Returns the number of rays traced (primary and
  // secondary), for the renderer's statistics.
  virtual uint64_t radiance(std::span<const Ray> rays, std::span<glm::vec3> radiance,
                            const Scene& scene, const Accel& accel) const = 0;
};

}  // namespace tritrace
