// The scene's emitters, their powers and the densities of sampling them.
#include "tritrace/render/light_sampler.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>

namespace tritrace {
namespace {

float mean(glm::vec3 c) {
  return (c.x + c.y + c.z) / 3.0f;
}

float triangle_area(const TriangleMesh& mesh, uint32_t prim) {
  return 0.5f * glm::length(glm::cross(mesh.e1()[prim], mesh.e2()[prim]));
}

}  // namespace

glm::vec3 emitted_radiance(const Material& m, glm::vec3 n, glm::vec3 w) {
  if (!m.emits()) return glm::vec3(0.0f);
  return m.two_sided || glm::dot(n, w) > 0.0f ? m.emission : glm::vec3(0.0f);
}

LightSampler::LightSampler(const Scene& scene) {
  std::vector<float> power;
  for (uint32_t i = 0; i < scene.lights.size(); ++i) {
    const float p = mean(scene.lights[i].power);
    if (!(p > 0.0f)) continue;
    lights_.push_back({i, true});
    power.push_back(p);
  }
  const TriangleMesh& mesh = scene.mesh;
  for (uint32_t prim = 0; prim < mesh.size(); ++prim) {
    const Material& m = scene.materials[mesh.material()[prim]];
    if (!m.emits()) continue;
    const float area = triangle_area(mesh, prim);
    // Flux of a Lambertian emitter: Le * area * pi per side.
    const float p = mean(m.emission) * area * kPi * (m.two_sided ? 2.0f : 1.0f);
    if (!(p > 0.0f) || !std::isfinite(p)) continue;
    lights_.push_back({prim, false});
    power.push_back(p);
    emissive_prims_.push_back(prim);
  }
  table_ = AliasTable(power);
  const size_t first_triangle = lights_.size() - emissive_prims_.size();
  for (size_t k = 0; k < emissive_prims_.size(); ++k) {
    emissive_pmf_.push_back(table_.pmf(static_cast<uint32_t>(first_triangle + k)));
  }
}

LightSample LightSampler::sample(const Scene& scene, glm::vec3 x, float u_select,
                                 glm::vec2 u_point) const {
  LightSample out;
  if (table_.empty()) return out;
  const AliasTable::Sample pick = table_.sample(u_select);
  const Light& light = lights_[pick.index];
  if (light.point) {
    const PointLight& p = scene.lights[light.index];
    out.point = p.position;
    out.radiance = p.power / (4.0f * kPi);  // intensity
    out.pdf = pick.pmf;                     // a probability, not a density: delta
    out.delta = true;
    return out;
  }
  const TriangleMesh& mesh = scene.mesh;
  const uint32_t prim = light.index;
  out.prim = prim;
  const glm::vec3 b = sample_uniform_triangle(u_point);
  const glm::vec3 v0 = mesh.v0()[prim];
  out.point = v0 + b.y * mesh.e1()[prim] + b.z * mesh.e2()[prim];
  out.normal = mesh.normal()[prim];
  const glm::vec3 to_x = x - out.point;
  const float dist2 = glm::dot(to_x, to_x);
  if (!(dist2 > 0.0f)) return out;
  const glm::vec3 w = to_x / std::sqrt(dist2);
  const float cos_light = std::abs(glm::dot(out.normal, w));
  out.radiance = emitted_radiance(scene.materials[mesh.material()[prim]], out.normal, w);
  if (!(cos_light > 0.0f)) return out;
  out.pdf = pick.pmf * dist2 / (triangle_area(mesh, prim) * cos_light);
  return out;
}

float LightSampler::pdf_triangle(const Scene& scene, uint32_t prim, glm::vec3 x,
                                 glm::vec3 y) const {
  const auto it = std::lower_bound(emissive_prims_.begin(), emissive_prims_.end(), prim);
  if (it == emissive_prims_.end() || *it != prim) return 0.0f;
  const float pmf = emissive_pmf_[static_cast<size_t>(it - emissive_prims_.begin())];
  const glm::vec3 d = x - y;
  const float dist2 = glm::dot(d, d);
  const float cos_light = std::abs(glm::dot(scene.mesh.normal()[prim], d)) / std::sqrt(dist2);
  if (!(cos_light > 0.0f)) return 0.0f;
  return pmf * dist2 / (triangle_area(scene.mesh, prim) * cos_light);
}

}  // namespace tritrace
