// Camera construction (the lab's orbit, look-at, field of view) and ray generation, following
// ../shared/lab-cornell-box.md.
#include "tritrace/scene/camera.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "tritrace/math/rotation.h"

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

}  // namespace tritrace
