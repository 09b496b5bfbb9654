// The scene's emitters, their powers and the densities of sampling them.
#include "tritrace/render/light_sampler.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>

#include "tritrace/math/offset_ray.h"

namespace tritrace {
namespace {

float mean(glm::vec3 c) {
  return (c.x + c.y + c.z) / 3.0f;
}

float triangle_area(glm::vec3 e1, glm::vec3 e2) {
  return 0.5f * glm::length(glm::cross(e1, e2));
}

}  // namespace

glm::vec3 emitted_radiance(const Material& m, glm::vec3 n, glm::vec3 w) {
  if (!m.emits()) return glm::vec3(0.0f);
  return m.two_sided || glm::dot(n, w) > 0.0f ? m.emission : glm::vec3(0.0f);
}

LightSampler::LightSampler(const Scene& scene) {
  std::vector<float> power;
  for (uint32_t i = 0; i < scene.lights.size(); ++i) {
    const PointLight& l = scene.lights[i];
    const float p = mean(l.power);
    if (!(p > 0.0f)) continue;
    Light light{};
    light.index = i;
    light.point = true;
    light.p0 = l.position;
    light.radiance = l.power / (4.0f * kPi);
    lights_.push_back(light);
    power.push_back(p);
  }
  for (uint32_t i = 0; i < scene.spot_lights.size(); ++i) {
    const float p = mean(spot_light_power(scene.spot_lights[i]));
    if (!(p > 0.0f) || !std::isfinite(p)) continue;
    Light light{};
    light.index = i;
    light.spot = true;
    lights_.push_back(light);
    power.push_back(p);
  }
  if (!scene.directional_lights.empty()) {
    // Weighed by the flux through the scene's bounding sphere; a scene of no extent (or one too
    // large for a float's r^2) falls back to E, any positive weight being unbiased.
    const Bounds3 b = scene_bounds(scene);
    const float radius = 0.5f * glm::length(b.hi - b.lo);
    for (uint32_t i = 0; i < scene.directional_lights.size(); ++i) {
      const DirectionalLight& l = scene.directional_lights[i];
      const float p = directional_light_weight(l, radius);
      if (p == 0.0f) continue;
      Light light{};
      light.index = i;
      light.directional = true;
      lights_.push_back(light);
      power.push_back(p);
    }
  }
  // Emissive triangles in the scene's numbering: the scene's own, then each instance's (in world
  // space, as the flattened scene would hold them), so that an instanced scene samples its lights
  // as its flattened copy does.
  auto add_triangle = [&](uint32_t prim, const SurfaceTriangle& t) {
    const Material& m = scene.materials[t.material];
    if (!m.emits()) return;
    const float area = triangle_area(t.e1, t.e2);
    // Flux of a Lambertian emitter: Le * area * pi per side.
    const float p = mean(m.emission) * area * kPi * (m.two_sided ? 2.0f : 1.0f);
    if (!(p > 0.0f) || !std::isfinite(p)) return;
    Light light{};
    light.index = prim;
    light.point = false;
    light.two_sided = m.two_sided;
    light.textured = m.emission_texture.present();
    light.p0 = t.v0;
    light.e1 = t.e1;
    light.e2 = t.e2;
    light.normal = t.normal;
    light.radiance = m.emission;
    light.extent = triangle_extent(light.e1, light.e2);
    lights_.push_back(light);
    power.push_back(p);
    emissive_prims_.push_back(prim);
  };
  const TriangleMesh& mesh = scene.mesh;
  for (uint32_t prim = 0; prim < mesh.size(); ++prim) {
    if (scene.materials[mesh.material()[prim]].emits())
      add_triangle(prim, stored_triangle(mesh, prim));
  }
  // Each prototype's emissive triangles, found once; instances then add theirs unless there would
  // be more than kMaxInstancedLights (a billion-triangle glowing city), which are left to BSDF
  // sampling alone: unbiased under MIS, noisier.
  std::vector<std::vector<uint32_t>> emissive_of(scene.prototypes.size());
  for (size_t p = 0; p < scene.prototypes.size(); ++p) {
    const TriangleMesh& proto = scene.prototypes[p];
    for (uint32_t k = 0; k < proto.size(); ++k) {
      if (scene.materials[proto.material()[k]].emits()) emissive_of[p].push_back(k);
    }
  }
  uint64_t instanced = 0;
  for (const Instance& inst : scene.instances) instanced += emissive_of[inst.prototype].size();
  if (instanced <= kMaxInstancedLights) {
    for (const Instance& inst : scene.instances) {
      for (uint32_t k : emissive_of[inst.prototype]) {
        add_triangle(inst.first_prim + k, scene.triangle(inst.first_prim + k));
      }
    }
  }
  if (scene.environment_map) {
    environment_ = EnvironmentLight(*scene.environment_map);
    has_environment_ = !environment_.black();
  }
  if (has_environment_) {
    // A light at infinity has no finite power to compare with the others' (pbrt estimates it over
    // the scene's bounding disk, which a ground plane or a far point light makes arbitrary): it is
    // chosen half the time when the scene has other lights, always when it has none.
    double others = 0.0;
    for (float p : power) others += static_cast<double>(p);
    Light light{};
    light.environment = true;
    lights_.push_back(light);
    power.push_back(others > 0.0 ? static_cast<float>(others) : 1.0f);
  }
  table_ = AliasTable(power);
  if (has_environment_) environment_pmf_ = table_.pmf(static_cast<uint32_t>(lights_.size() - 1));
  for (size_t k = 0; k < lights_.size(); ++k) {
    Light& light = lights_[k];
    if (light.point || light.spot || light.directional || light.environment) continue;
    light.pmf_over_area = table_.pmf(static_cast<uint32_t>(k)) / triangle_area(light.e1, light.e2);
    emissive_pmf_over_area_.push_back(light.pmf_over_area);
  }
  untextured_triangles_only_ =
      !table_.empty() && std::all_of(lights_.begin(), lights_.end(), [](const Light& l) {
        return !l.point && !l.spot && !l.directional && !l.environment && !l.textured;
      });
}

LightSample LightSampler::sample(const Scene& scene, glm::vec3 x, float u_select,
                                 glm::vec2 u_point) const {
  LightSample out;
  if (table_.empty()) return out;
  const AliasTable::Sample pick = table_.sample(u_select);
  const Light& light = lights_[pick.index];
  if (light.environment) {
    const EnvironmentLight::Sample e = environment_.sample(u_point);
    out.infinite = true;
    out.wi = e.wi;
    out.point = x + e.wi;
    out.radiance = e.radiance;
    out.pdf = pick.pmf * e.pdf;
    return out;
  }
  if (light.spot) {
    const SpotLight& s = scene.spot_lights[light.index];
    out.point = s.position;
    const glm::vec3 from_light = x - s.position;
    const float dist2 = glm::dot(from_light, from_light);
    if (!(dist2 > 0.0f)) return out;
    out.radiance =
        s.intensity * spot_falloff(s, glm::dot(s.direction, from_light) / std::sqrt(dist2));
    out.pdf = pick.pmf;
    out.delta = true;
    return out;
  }
  if (light.directional) {
    const DirectionalLight& d = scene.directional_lights[light.index];
    out.infinite = true;
    out.delta = true;
    out.wi = -d.direction;
    out.point = x + out.wi;
    out.radiance = d.irradiance;
    out.pdf = pick.pmf;
    return out;
  }
  if (light.point) {
    out.point = light.p0;
    out.radiance = light.radiance;  // intensity
    out.pdf = pick.pmf;             // a probability, not a density: delta
    out.delta = true;
    return out;
  }
  out.prim = light.index;
  out.extent = light.extent;
  const glm::vec3 b = sample_uniform_triangle(u_point);
  out.point = light.p0 + b.y * light.e1 + b.z * light.e2;
  out.normal = light.normal;
  const glm::vec3 to_x = x - out.point;
  const float dist2 = glm::dot(to_x, to_x);
  if (!(dist2 > 0.0f)) return out;
  const float cos_out = glm::dot(light.normal, to_x);  // times the distance
  if (!(light.two_sided || cos_out > 0.0f)) return out;
  const float cos_light = std::abs(cos_out) / std::sqrt(dist2);
  if (!(cos_light > 0.0f)) return out;
  out.radiance = light.radiance;
  if (light.textured) {
    const Material& m = scene.materials[scene.material_of(light.index)];
    out.radiance = textured(scene, m.emission_texture, light.radiance, light.index, b.y, b.z);
  }
  out.pdf = light.pmf_over_area * dist2 / cos_light;
  return out;
}

float LightSampler::pdf_triangle(const Scene& scene, uint32_t prim, glm::vec3 x,
                                 glm::vec3 y) const {
  const auto it = std::lower_bound(emissive_prims_.begin(), emissive_prims_.end(), prim);
  if (it == emissive_prims_.end() || *it != prim) return 0.0f;
  const float pmf_over_area =
      emissive_pmf_over_area_[static_cast<size_t>(it - emissive_prims_.begin())];
  const glm::vec3 d = x - y;
  const float dist2 = glm::dot(d, d);
  const glm::vec3 normal =
      prim < scene.mesh.size() ? scene.mesh.normal()[prim] : scene.triangle(prim).normal;
  const float cos_light = std::abs(glm::dot(normal, d)) / std::sqrt(dist2);
  if (!(cos_light > 0.0f)) return 0.0f;
  return pmf_over_area * dist2 / cos_light;
}

}  // namespace tritrace
