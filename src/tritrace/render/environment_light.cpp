// The map's directions, texel lookups and its sampling density: a texel's share of the 2-D
// distribution is luminance * sin(theta at its centre) (a texel near a pole covers less solid
// angle), and the density in (u, v) turns into solid angle by dividing by the Jacobian
// d(omega) / d(u, v) = 2 pi^2 sin(theta).
#include "tritrace/render/environment_light.h"

#include <algorithm>
#include <cmath>

#include "tritrace/math/sampling.h"

namespace tritrace {

namespace {

// sin(theta) from the up axis (-y) of a unit direction: its length across the axis (rotation about
// the axis leaves it unchanged).
float sin_theta_of(glm::vec3 dir) {
  return std::sqrt(dir.x * dir.x + dir.z * dir.z);
}

}  // namespace

EnvironmentLight::EnvironmentLight(const EnvironmentMap& map)
    : width_(map.width), height_(map.height), radiance_(map.texels.size()) {
  const double radians = static_cast<double>(map.rotate_degrees) * (kPi / 180.0);
  cos_rotate_ = static_cast<float>(std::cos(radians));
  sin_rotate_ = static_cast<float>(std::sin(radians));
  std::vector<float> weights(map.texels.size());
  double solid_angle_sum = 0.0;
  for (int y = 0; y < height_; ++y) {
    const double theta = kPi * (y + 0.5) / height_;
    const float sin_theta = static_cast<float>(std::sin(theta));
    for (int x = 0; x < width_; ++x) {
      const size_t i =
          static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x);
      radiance_[i] = map.texels[i] * map.scale;
      weights[i] = luminance(radiance_[i]) * sin_theta;
      solid_angle_sum += static_cast<double>(weights[i]);
    }
  }
  distribution_ = PiecewiseConstant2D(weights, width_, height_);
  // Integral of L sin(theta) over (theta, phi) divided by 4 pi, with dtheta dphi = 2 pi^2 / texels.
  if (width_ > 0 && height_ > 0) {
    mean_luminance_ = static_cast<float>(solid_angle_sum * 2.0 * kPi * kPi /
                                         (static_cast<double>(width_) * height_) / (4.0 * kPi));
  }
}

glm::vec2 EnvironmentLight::uv_of(glm::vec3 dir) const {
  // Undo the rotation about the up axis (-y), which carries +z towards +x.
  const float x = cos_rotate_ * dir.x - sin_rotate_ * dir.z;
  const float z = sin_rotate_ * dir.x + cos_rotate_ * dir.z;
  const float phi = std::atan2(x, z);  // 0 at +z, pi / 2 at +x
  // atan2 rather than acos(-y): near the poles y rounds to +-1 and acos loses theta's digits.
  const float theta = std::atan2(std::sqrt(x * x + z * z), -dir.y);
  float u = phi * (0.5f * kInvPi) + 0.5f;
  if (u >= 1.0f) u -= 1.0f;
  if (u < 0.0f) u += 1.0f;
  return {u, theta * kInvPi};
}

glm::vec3 EnvironmentLight::direction_of(glm::vec2 uv) const {
  const float theta = kPi * uv.y;
  const float phi = 2.0f * kPi * (uv.x - 0.5f);
  const float sin_theta = std::sin(theta);
  const float x = sin_theta * std::sin(phi), z = sin_theta * std::cos(phi);
  return {cos_rotate_ * x + sin_rotate_ * z, -std::cos(theta), -sin_rotate_ * x + cos_rotate_ * z};
}

int EnvironmentLight::texel_index(glm::vec2 uv, int* x, int* y) const {
  *x = std::clamp(static_cast<int>(uv.x * static_cast<float>(width_)), 0, width_ - 1);
  *y = std::clamp(static_cast<int>(uv.y * static_cast<float>(height_)), 0, height_ - 1);
  return *y * width_ + *x;
}

glm::vec3 EnvironmentLight::radiance(glm::vec3 dir) const {
  if (radiance_.empty()) return glm::vec3(0.0f);
  int x = 0, y = 0;
  return radiance_[static_cast<size_t>(texel_index(uv_of(dir), &x, &y))];
}

float EnvironmentLight::pdf(glm::vec3 dir) const {
  if (black()) return 0.0f;
  const glm::vec2 uv = uv_of(dir);
  const float sin_theta = sin_theta_of(dir);
  if (!(sin_theta > 0.0f)) return 0.0f;
  int x = 0, y = 0;
  texel_index(uv, &x, &y);
  return distribution_.pdf(x, y) / (2.0f * kPi * kPi * sin_theta);
}

EnvironmentLight::Sample EnvironmentLight::sample(glm::vec2 u) const {
  Sample s;
  if (black()) return s;
  const PiecewiseConstant2D::Sample d = distribution_.sample(u);
  const glm::vec3 wi = direction_of(d.uv);
  // sin(theta) of the direction itself, as pdf() computes it, so that the two agree to the last
  // bits near the poles too.
  const float sin_theta = sin_theta_of(wi);
  if (!(sin_theta > 0.0f) || !(d.pdf > 0.0f)) return s;
  s.wi = wi;
  s.radiance = radiance_[static_cast<size_t>(d.y * width_ + d.x)];
  s.pdf = d.pdf / (2.0f * kPi * kPi * sin_theta);
  return s;
}

}  // namespace tritrace
