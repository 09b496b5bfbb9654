// Scene: everything a render reads, built once and then read-only: triangles, materials, point
// lights, the constant indirect (ambient) term and the camera.
#pragma once

#include <glm/vec3.hpp>
#include <vector>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/scene/camera.h"

namespace tritrace {

struct Material {
  glm::vec3 albedo{0.75f};  // diffuse reflectance rho, linear RGB
};

struct PointLight {
  glm::vec3 position{0.0f};
  glm::vec3 power{0.0f};  // P, radiant power per channel
};

struct Scene {
  TriangleMesh mesh;
  std::vector<Material> materials;
  std::vector<PointLight> lights;
  glm::vec3 ambient{0.0f};  // the lab's constant indirect light N
  Camera camera;
};

}  // namespace tritrace
