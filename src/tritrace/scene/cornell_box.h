// The lab's Cornell box: 30 coloured triangles scaled to [-1, 1]^3, its point light, its constant
// indirect light and its camera, exactly as ../shared/lab-cornell-box.md gives them.
#pragma once

#include <glm/vec3.hpp>

#include "tritrace/scene/scene.h"

namespace tritrace {

inline constexpr glm::vec3 kLabLightPosition{0.0f, -0.5f, -0.7f};
inline constexpr glm::vec3 kLabLightPower{14.0f, 14.0f, 14.0f};
inline constexpr glm::vec3 kLabAmbient{0.5f, 0.5f, 0.5f};
inline constexpr float kLabCameraDistance = 3.0f;

struct CornellOptions {
  int width = 500;
  int height = 500;
  double yaw = 0.0;  // radians, orbit about the y axis
  glm::vec3 light_position = kLabLightPosition;
};

Scene make_cornell_box(const CornellOptions& options = {});

// The classic Cornell box light: the quad (343, 554, 227), (343, 554, 332), (213, 554, 332),
// (213, 554, 227) in the box's 555-unit coordinates, mapped like the box's vertices.
inline constexpr glm::vec3 kAreaLightRadiance{10.0f, 10.0f, 10.0f};

// The lab's box (the same 30 triangles and colours, camera and ambient) without the point light,
// lit by the ceiling quad above as two emissive triangles (32 in all, after the box's 30): they
// emit kAreaLightRadiance from their lower face only, towards the floor, and reflect nothing.
Scene make_cornell_area(const CornellOptions& options = {});

}  // namespace tritrace
