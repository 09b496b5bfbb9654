// The AOVs every integrator writes the same way.
#include "tritrace/render/integrator.h"

#include <glm/geometric.hpp>

namespace tritrace {

void write_first_hit_aovs(const Scene& scene, std::span<const Ray> rays, std::span<const Hit> hits,
                          const SampleOutput& out) {
  if (out.albedo.empty() && out.normal.empty() && out.depth.empty()) return;
  for (size_t i = 0; i < hits.size(); ++i) {
    const Hit& h = hits[i];
    if (!out.albedo.empty()) {
      glm::vec3 albedo(0.0f);
      if (h.found()) {
        const Material& m = scene.materials[scene.material_of(h.prim)];
        // Textured as the path tracer shades it.
        albedo = surface_albedo(scene, m, h.prim, h.u, h.v);
      }
      out.albedo[i] = albedo;
    }
    if (!out.normal.empty()) {
      glm::vec3 n(0.0f);
      if (h.found()) {
        n = scene.triangle(h.prim).normal;
        if (glm::dot(n, rays[i].dir) > 0.0f) n = -n;
      }
      out.normal[i] = n;
    }
    if (!out.depth.empty()) out.depth[i] = h.found() ? h.t : 0.0f;
  }
}

}  // namespace tritrace
