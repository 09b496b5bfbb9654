// EnvironmentLight: an equirectangular radiance map (scene.h's EnvironmentMap, whose comment gives
// the axes) as a light at infinity, importance-sampled in proportion to luminance * sin(theta)
// over its texels, with the solid-angle density that next-event estimation and MIS need.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <vector>

#include "tritrace/math/piecewise_constant.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

class EnvironmentLight {
 public:
  EnvironmentLight() = default;
  explicit EnvironmentLight(const EnvironmentMap& map);

  // Whether the map sends no light at all (then it is never sampled).
  bool black() const { return distribution_.zero(); }

  // The radiance arriving from world direction `dir` (unit; pointing away from the scene).
  glm::vec3 radiance(glm::vec3 dir) const;
  // The solid-angle density with which sample() returns `dir`.
  float pdf(glm::vec3 dir) const;

  struct Sample {
    glm::vec3 wi{0.0f};  // world direction towards the environment
    glm::vec3 radiance{0.0f};
    float pdf = 0.0f;  // solid angle; 0 when the map is black
  };
  Sample sample(glm::vec2 u) const;

  // The map's (u, v) of a world direction and back (exposed for the tests).
  glm::vec2 uv_of(glm::vec3 dir) const;
  glm::vec3 direction_of(glm::vec2 uv) const;

  // The map's luminance averaged over the sphere's solid angle (its irradiance on an unoccluded
  // plane is pi times it). The light sampler does not choose by it: a map is chosen half the time
  // beside other lights (light_sampler.cpp), since its power has no finite scale to compare.
  float mean_luminance() const { return mean_luminance_; }

 private:
  int texel_index(glm::vec2 uv, int* x, int* y) const;

  int width_ = 0, height_ = 0;
  std::vector<glm::vec3> radiance_;  // texels times scale
  float cos_rotate_ = 1.0f, sin_rotate_ = 0.0f;
  PiecewiseConstant2D distribution_;
  float mean_luminance_ = 0.0f;
};

// Rec. 709 luminance of linear RGB.
inline float luminance(glm::vec3 c) {
  return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
}

}  // namespace tritrace
