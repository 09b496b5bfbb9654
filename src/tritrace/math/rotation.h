// The lab's rotation about the y axis, R_y(a) = [[cos a, 0, sin a], [0, 1, 0], [-sin a, 0, cos a]]
// (rows), written out so that the orbit camera matches the lab bit for bit.
#pragma once

#include <cmath>
#include <glm/vec3.hpp>

namespace tritrace {

struct RotationY {
  float c = 1.0f;
  float s = 0.0f;

  static RotationY from_angle(double radians) {
    return {static_cast<float>(std::cos(radians)), static_cast<float>(std::sin(radians))};
  }
  glm::vec3 apply(glm::vec3 v) const { return {c * v.x + s * v.z, v.y, -s * v.x + c * v.z}; }
};

}  // namespace tritrace
