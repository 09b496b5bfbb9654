// LightSampler: every emitter of a scene (point, spot and directional lights, emissive triangles
// and an environment map) in one list, chosen in proportion to its power through an alias table,
// with the densities that next-event estimation and multiple importance sampling need. Built once
// per scene, then read-only.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "tritrace/math/sampling.h"
#include "tritrace/render/environment_light.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

struct LightSample {
  glm::vec3 point{0.0f};   // on the light
  glm::vec3 normal{0.0f};  // the light's lab normal at `point` (zero for a delta light)
  // Le towards the shading point; for a point or spot light its intensity towards it (W/sr), for
  // a directional light its irradiance (W/m^2) on a surface facing it.
  glm::vec3 radiance{0.0f};
  // Solid angle density at the shading point; for a delta light the probability of choosing it.
  float pdf = 0.0f;
  bool delta = false;     // a point, spot or directional light: no other strategy can sample it
  bool infinite = false;  // the environment map or a directional light: `wi` is the direction
                          // and `point` is x + wi
  glm::vec3 wi{0.0f};     // towards the light (infinite only)
  uint32_t prim = 0;      // the emissive triangle (unused for a point light)
  float extent = 0.0f;    // the triangle's largest edge component (for the shadow ray's end)
};

// Emissive triangles of instances beyond this many are not light-sampled (found by BSDF sampling
// only, which MIS keeps unbiased): a list of them all could outgrow memory on huge instanced
// scenes.
inline constexpr uint64_t kMaxInstancedLights = uint64_t{1} << 22;

class LightSampler {
 public:
  explicit LightSampler(const Scene& scene);

  bool empty() const { return table_.empty(); }
  size_t size() const { return lights_.size(); }

  // Chooses a light with u_select and a point on it with u_point, as seen from x. pdf 0 when the
  // sample carries nothing (a triangle seen from behind, x on the light's plane).
  LightSample sample(const Scene& scene, glm::vec3 x, float u_select, glm::vec2 u_point) const;

  // The solid angle density with which sample() picks the point `y` of emissive triangle `prim`
  // seen from x (for the MIS weight of a BSDF-sampled ray that hit it); 0 for a non-emitter.
  float pdf_triangle(const Scene& scene, uint32_t prim, glm::vec3 x, glm::vec3 y) const;

  // The probability of choosing light i (point lights first, then spot lights, directional lights,
  // emissive triangles in mesh order, then the environment map), for tests. Each is chosen in
  // proportion to its power (spot_light_power, directional_light_power).
  float pmf(size_t i) const { return table_.pmf(static_cast<uint32_t>(i)); }

  // The scene's environment map (empty when it has none), and the solid-angle density with which
  // sample() picks direction `dir` of it (for the MIS weight of a BSDF-sampled ray that escaped).
  const EnvironmentLight* environment() const { return has_environment_ ? &environment_ : nullptr; }
  float pdf_environment(glm::vec3 dir) const {
    return has_environment_ ? environment_pmf_ * environment_.pdf(dir) : 0.0f;
  }

  // What sampling a light reads, in one place (no trips through the scene's arrays): for a point
  // light its position and intensity; for a triangle its vertex, edges, normal and radiance. A spot
  // or directional light is read from the scene's list.
  struct Light {
    uint32_t index;  // into scene.lights (point), spot_lights, directional_lights, else the prim
    bool point;
    bool spot;
    bool directional;
    bool environment;
    bool two_sided;
    bool textured;  // its material has an emission texture
    glm::vec3 p0, e1, e2, normal;
    glm::vec3 radiance;   // Le, or a point light's intensity P / (4 pi)
    float pmf_over_area;  // the probability of choosing it, per unit area (triangles)
    float extent;         // the triangle's largest edge component, for ray offsets
  };

  // Whether every light is an emissive triangle without an emission texture: then sample() is
  // pick(u_select) followed by the triangle branch of sample() on light(pick.index), which the
  // path tracer runs for eight vertices at a time.
  bool untextured_triangles_only() const { return untextured_triangles_only_; }
  AliasTable::Sample pick(float u_select) const { return table_.sample(u_select); }
  const Light& light(uint32_t index) const { return lights_[index]; }

 private:
  std::vector<Light> lights_;
  std::vector<uint32_t> emissive_prims_;       // sorted, for pdf_triangle
  std::vector<float> emissive_pmf_over_area_;  // parallel to emissive_prims_
  AliasTable table_;
  EnvironmentLight environment_;
  bool has_environment_ = false;  // a map that is not black
  float environment_pmf_ = 0.0f;
  bool untextured_triangles_only_ = false;
};

// The radiance an emissive material sends from a triangle with lab normal `n` along `w` (pointing
// away from the surface): Le on the front (dot(n, w) > 0) or on both sides when two-sided.
glm::vec3 emitted_radiance(const Material& m, glm::vec3 n, glm::vec3 w);

}  // namespace tritrace
