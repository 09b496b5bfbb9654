// Camera construction (the lab's orbit, look-at, field of view) and ray generation, following
// ../shared/lab-cornell-box.md.
#include "tritrace/scene/camera.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "tritrace/math/rotation.h"
#include "tritrace/math/sampling.h"
#include "tritrace/math/simd_lanes.h"

namespace tritrace {

Camera::Camera(int width, int height, glm::vec3 position, glm::vec3 right, glm::vec3 down,
               glm::vec3 forward, float focal_px)
    : width_(width),
      height_(height),
      focal_(focal_px > 0.0f ? focal_px : static_cast<float>(height)),
      position_(position),
      right_(right),
      down_(down),
      forward_(forward) {}

// The basis is R_y(yaw)'s columns, so that primary_ray computes the lab's R_y(yaw) * d: the extra
// products with the matrix's exact zeros add signed zeros, which leave every sum's value unchanged.
Camera::Camera(int width, int height, double yaw, float distance, float focal_px)
    : Camera(width, height, RotationY::from_angle(yaw).apply(glm::vec3(0.0f, 0.0f, -distance)),
             RotationY::from_angle(yaw).apply(glm::vec3(1.0f, 0.0f, 0.0f)),
             RotationY::from_angle(yaw).apply(glm::vec3(0.0f, 1.0f, 0.0f)),
             RotationY::from_angle(yaw).apply(glm::vec3(0.0f, 0.0f, 1.0f)), focal_px) {}

bool Camera::is_valid_look_at(glm::vec3 position, glm::vec3 target, glm::vec3 up) {
  const glm::vec3 view = target - position;
  if (!(glm::dot(view, view) > 0.0f) || !(glm::dot(up, up) > 0.0f)) return false;
  const glm::vec3 side = glm::cross(glm::normalize(view), glm::normalize(up));
  return glm::dot(side, side) > 1e-12f;
}

Camera Camera::look_at(int width, int height, glm::vec3 position, glm::vec3 target, glm::vec3 up,
                       float focal_px) {
  const glm::vec3 forward = glm::normalize(target - position);
  // Image right is forward x up; image down completes the right-handed basis (right, down,
  // forward), which for the lab's up (0, -1, 0) is exactly the identity.
  const glm::vec3 right = glm::normalize(glm::cross(forward, up));
  const glm::vec3 down = glm::cross(forward, right);
  return Camera(width, height, position, right, down, forward, focal_px);
}

float Camera::focal_for_vertical_fov(int height, double degrees) {
  const double half = degrees * std::numbers::pi / 360.0;
  return static_cast<float>(0.5 * height / std::tan(half));
}

Ray Camera::lens_ray(float px, float py, glm::vec2 u) const {
  Ray ray = ray_through(px, py);
  if (!(lens_radius_ > 0.0f)) return ray;
  const glm::vec3 in_focus = ray.origin + ray.dir * (focus_distance_ / glm::dot(ray.dir, forward_));
  const glm::vec2 lens = lens_radius_ * sample_uniform_disk_concentric(u);
  ray.origin += right_ * lens.x + down_ * lens.y;
  ray.dir = glm::normalize(in_focus - ray.origin);
  return ray;
}

void Camera::primary_rays(int x0, int y0, int x1, int y1, Ray* out) const {
  const int row = x1 - x0, count = row * (y1 - y0);
  int i = 0;
#if TRITRACE_SIMD_LANES > 0
  // Lane by lane the operations of primary_ray: d from the basis, then glm::normalize's
  // d * (1 / sqrt(dot(d, d))). Each ray's fields are written one by one, straight into `out`:
  // building a Ray in a temporary and copying it (what the compiler does with primary_ray) stalls
  // on the copy's wide load of freshly stored floats.
  using simd::VF;
  using simd::VI;
  constexpr int W = simd::kLanes;
  const int half_width = width_ / 2, half_height = height_ / 2;
  const VF rx = simd::splat(right_.x), ry = simd::splat(right_.y), rz = simd::splat(right_.z);
  const VF dnx = simd::splat(down_.x), dny = simd::splat(down_.y), dnz = simd::splat(down_.z);
  const VF fx = simd::splat(forward_.x * focal_), fy = simd::splat(forward_.y * focal_),
           fz = simd::splat(forward_.z * focal_);
  // Rows 4 wide (the renderer's blocks) fill whole vectors of W / 4 rows; other shapes go pixel by
  // pixel below. The offsets are integers, converted once, as primary_ray does.
  static_assert(W % 4 == 0);
  for (; row == 4 && ortho_scale_ == 0.0f && i + W <= count; i += W) {
    const VI column = simd::splat_i(x0 - half_width) + simd::quad_column();
    const VI line = simd::splat_i(y0 + i / 4 - half_height) + simd::quad_row();
    const VF dx = simd::to_float(column), dy = simd::to_float(line);
    const VF d_x = rx * dx + dnx * dy + fx;
    const VF d_y = ry * dx + dny * dy + fy;
    const VF d_z = rz * dx + dnz * dy + fz;
    const VF scale = simd::splat(1.0f) / simd::sqrt(d_x * d_x + d_y * d_y + d_z * d_z);
    alignas(64) float dir[3][W];
    simd::store(dir[0], d_x * scale);
    simd::store(dir[1], d_y * scale);
    simd::store(dir[2], d_z * scale);
    for (int l = 0; l < W; ++l) {
      Ray& ray = out[i + l];
      ray.origin = position_;
      ray.dir.x = dir[0][l];
      ray.dir.y = dir[1][l];
      ray.dir.z = dir[2][l];
      ray.tmin = 0.0f;
      ray.tmax = kRayTMax;
    }
  }
#endif
  for (; i < count; ++i) out[i] = primary_ray(x0 + i % row, y0 + i / row);
}

}  // namespace tritrace
