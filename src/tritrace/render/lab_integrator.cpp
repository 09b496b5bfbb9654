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

ShadowRay lab_shadow_ray(const TriangleMesh& mesh, const Hit& hit, glm::vec3 light,
                         const RayOffsetParams& offset) {
  ShadowRay s;
  const uint32_t prim = hit.prim;
  const glm::vec3 e1 = mesh.e1()[prim], e2 = mesh.e2()[prim];
  // From the barycentrics rather than origin + t * dir: the error is then relative to the
  // triangle's own coordinates, not to the distance the primary ray travelled.
  const glm::vec3 x = mesh.v0()[prim] + hit.u * e1 + hit.v * e2;
  const glm::vec3 r = light - x;
  s.dist2 = glm::dot(r, r);
  const float dist = std::sqrt(s.dist2);
  const glm::vec3 dir = r / dist;
  const glm::vec3 normal = mesh.normal()[prim];
  s.cos_theta = glm::dot(dir, normal);
  // Facing away (or the hit sits on the light): no direct light, no shadow ray needed.
  if (!(s.cos_theta > 0.0f) || !(dist > 0.0f)) return s;
  // cos_theta > 0: the light is on the side the normal points to. A hit on an edge where two walls
  // meet lies on the other wall's plane too, and moving it along its own normal keeps it there (at
  // a right angle): the shadow ray would start on that wall and, with rounding, slip through it.
  // So the point first moves the same way towards its triangle's centroid, off every edge's
  // neighbour, then off its own surface.
  const float extent = triangle_extent(e1, e2);
  const glm::vec3 inward = mesh.v0()[prim] + (e1 + e2) / 3.0f - x;
  const float inward_length = std::sqrt(glm::dot(inward, inward));
  const glm::vec3 inside =
      inward_length > 0.0f ? offset_ray_origin(x, inward / inward_length, extent, offset) : x;
  const glm::vec3 start = offset_ray_origin(inside, normal, extent, offset);
  const glm::vec3 end = offset_ray_origin(light, -dir, extent, offset);
  const glm::vec3 segment = end - start;
  const float length = std::sqrt(glm::dot(segment, segment));
  if (!(length > 0.0f) || !(glm::dot(segment, r) > 0.0f)) {
    s.kind = ShadowRay::Kind::kLit;
    return s;
  }
  s.kind = ShadowRay::Kind::kTrace;
  s.ray.origin = start;
  s.ray.dir = segment / length;
  s.ray.tmin = 0.0f;
  s.ray.tmax = length;
  return s;
}

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

  for (const PointLight& light : scene.lights) {
    size_t m = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!hits[i].found()) continue;
      const ShadowRay shadow = lab_shadow_ray(scene.mesh, hits[i], light.position, offset_);
      if (shadow.kind == ShadowRay::Kind::kBehind) continue;
      const float weight = shadow.cos_theta / (4.0f * glm::pi<float>() * shadow.dist2);
      if (shadow.kind == ShadowRay::Kind::kLit) {
        direct[i] += light.power * weight;
        continue;
      }
      shadow_rays[m] = shadow.ray;
      shadow_weight[m] = weight;
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
