// The lab shading, batched: all primary hits of a tile first, then one shadow batch per light.
#include "tritrace/render/lab_integrator.h"

#include <array>
#include <cassert>
#include <glm/glm.hpp>
#include <glm/gtc/constants.hpp>

namespace tritrace {
namespace {

// The batch's hits and shadow rays, kept per thread: Hit and Ray initialise their members, and
// doing that for 256 of each on every tile cost more than a tenth of a Cornell box frame.
struct Scratch {
  std::array<Hit, kMaxBatch> hits;
  std::array<Ray, kMaxBatch> shadow_rays;
};

Scratch& thread_scratch() {
  thread_local Scratch scratch;
  return scratch;
}

}  // namespace

uint64_t LabIntegrator::radiance(std::span<const Ray> rays, std::span<glm::vec3> radiance,
                                 const Scene& scene, const Accel& accel) const {
  assert(rays.size() <= kMaxBatch && radiance.size() == rays.size());
  const size_t n = rays.size();
  Scratch& scratch = thread_scratch();
  std::array<Hit, kMaxBatch>& hits = scratch.hits;
  accel.intersect(rays, std::span(hits).first(n));

  std::array<glm::vec3, kMaxBatch> direct;
  std::fill_n(direct.begin(), n, glm::vec3(0.0f));
  std::array<Ray, kMaxBatch>& shadow_rays = scratch.shadow_rays;
  std::array<float, kMaxBatch> shadow_weight;  // max(n.r, 0) / (4 pi |r|^2)
  std::array<uint32_t, kMaxBatch> shadow_owner;
  std::array<uint8_t, kMaxBatch> blocked;
  uint64_t traced = n;

  const std::vector<glm::vec3>& normals = scene.mesh.normal();
  for (const PointLight& light : scene.lights) {
    size_t m = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!hits[i].found()) continue;
      const glm::vec3 x = rays[i].at(hits[i].t);
      const glm::vec3 r = light.position - x;
      const float dist2 = glm::dot(r, r);
      const float dist = std::sqrt(dist2);
      const glm::vec3 dir = r / dist;
      const float cos_theta = glm::dot(dir, normals[hits[i].prim]);
      // Facing away (or the hit sits on the light): no direct light, no shadow ray needed.
      if (!(cos_theta > 0.0f) || !(dist > 0.0f)) continue;
      Ray& s = shadow_rays[m];
      s.origin = x + kLabShadowOffset * dir;
      s.dir = dir;
      s.tmin = 0.0f;
      s.tmax = dist - kLabShadowOffset;
      shadow_weight[m] = cos_theta / (4.0f * glm::pi<float>() * dist2);
      shadow_owner[m] = static_cast<uint32_t>(i);
      ++m;
    }
    accel.occluded(std::span<const Ray>(shadow_rays.data(), m), std::span(blocked).first(m));
    traced += m;
    for (size_t j = 0; j < m; ++j) {
      if (!blocked[j]) direct[shadow_owner[j]] += light.power * shadow_weight[j];
    }
  }

  for (size_t i = 0; i < n; ++i) {
    if (!hits[i].found()) {
      radiance[i] = glm::vec3(0.0f);
      continue;
    }
    const glm::vec3& albedo = scene.materials[scene.mesh.material()[hits[i].prim]].albedo;
    radiance[i] = albedo * (direct[i] + scene.ambient);
  }
  return traced;
}

}  // namespace tritrace
