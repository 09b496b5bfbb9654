// Scene: everything a render reads, built once and then read-only: triangles, materials, point
// lights, the constant indirect (ambient) term and the camera.
#pragma once

#include <glm/vec3.hpp>
#include <vector>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/scene/camera.h"

namespace tritrace {

// A two-sided Lambertian (diffuse) surface that may also emit light.
struct Material {
  glm::vec3 albedo{0.75f};  // diffuse reflectance rho, linear RGB
  // Emitted radiance Le (linear RGB, W/(m^2 sr) per channel), from the triangle's front (the side
  // its lab normal, normalize(cross(e2, e1)), points to), or from both sides when two_sided.
  glm::vec3 emission{0.0f};
  bool two_sided = false;

  bool emits() const { return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f; }
};

// Radiates intensity power / (4 pi) in every direction (the lab's light).
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
