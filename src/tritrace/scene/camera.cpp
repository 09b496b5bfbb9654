// Camera ray generation, following ../shared/lab-cornell-box.md.
#include "tritrace/scene/camera.h"

#include <glm/geometric.hpp>

namespace tritrace {

Camera::Camera(int width, int height, double yaw, float distance, float focal_px)
    : width_(width),
      height_(height),
      yaw_(yaw),
      distance_(distance),
      focal_(focal_px > 0.0f ? focal_px : static_cast<float>(height)),
      rot_(RotationY::from_angle(yaw)),
      position_(rot_.apply(glm::vec3(0.0f, 0.0f, -distance))) {}

}  // namespace tritrace
