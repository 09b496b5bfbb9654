// The lab's pinhole camera: it orbits the origin at `distance`, turned by `yaw` about the y axis,
// and looks at the centre. Pixel (x, y) looks along R_y(yaw) * (x - W/2, y - H/2, f) with integer
// W/2 and H/2 (the pixel corner, as the lab does) and f = H by default; world y points down.
#pragma once

#include <glm/geometric.hpp>

#include "tritrace/math/ray.h"
#include "tritrace/math/rotation.h"

namespace tritrace {

class Camera {
 public:
  Camera() : Camera(500, 500) {}
  // focal_px <= 0 means the lab's default, f = height.
  Camera(int width, int height, double yaw = 0.0, float distance = 3.0f, float focal_px = 0.0f);

  int width() const { return width_; }
  int height() const { return height_; }
  double yaw() const { return yaw_; }
  float distance() const { return distance_; }
  float focal_px() const { return focal_; }
  glm::vec3 position() const { return position_; }

  // The ray through pixel (x, y); its direction is normalised, so t is a distance.
  Ray primary_ray(int x, int y) const {
    const glm::vec3 d(static_cast<float>(x - width_ / 2), static_cast<float>(y - height_ / 2),
                      focal_);
    Ray ray;
    ray.origin = position_;
    ray.dir = glm::normalize(rot_.apply(d));
    return ray;
  }

 private:
  int width_, height_;
  double yaw_;
  float distance_;
  float focal_;
  RotationY rot_;
  glm::vec3 position_;
};

}  // namespace tritrace
