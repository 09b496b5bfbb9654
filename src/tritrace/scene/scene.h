// Scene: everything a render reads, built once and then read-only: triangles, materials, point
// lights, the constant indirect (ambient) term and the camera.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <memory>
#include <string>
#include <vector>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/scene/camera.h"

namespace tritrace {

// What a surface does with light (render/material/bsdf.h builds its BSDF from this). The lab
// integrator reads only `albedo` (and shades every type as diffuse, with the lab's one-sided rule).
enum class MaterialType : uint8_t {
  kDiffuse,    // two-sided Lambert, reflectance `albedo`
  kConductor,  // metal: GGX microfacets (a mirror at roughness 0), Schlick Fresnel from F0 = albedo
               // or the exact Fresnel of a complex index (conductor_eta, conductor_k)
  kDielectric,  // glass: GGX reflection and refraction with exact Fresnel, index `ior` inside
  kPrincipled,  // glTF metallic-roughness: conductor, glass and coated diffuse mixed by weights
};

// A surface material that may also emit light.
struct Material {
  glm::vec3 albedo{0.75f};  // diffuse reflectance rho (or F0, or transmission tint), linear RGB
  // Emitted radiance Le (linear RGB, W/(m^2 sr) per channel), from the triangle's front (the side
  // its lab normal, normalize(cross(e2, e1)), points to), or from both sides when two_sided.
  glm::vec3 emission{0.0f};
  bool two_sided = false;
  MaterialType type = MaterialType::kDiffuse;
  // Perceptual roughness in [0, 1]; the GGX width is alpha = roughness^2 (glTF's and Blender's
  // convention). Below kSmoothAlpha the surface is treated as perfectly smooth (a delta lobe).
  float roughness = 0.0f;
  // Index of refraction of the material's inside (the side opposite its lab normal) relative to
  // the outside; dielectric and principled only.
  float ior = 1.5f;
  float metallic = 0.0f;      // principled only: the conductor's weight
  float transmission = 0.0f;  // principled only: the glass lobe's share of the non-metal weight
  // Conductor only: the metal's complex index of refraction n + i k per channel (relative to the
  // outside). When conductor_eta.x > 0 the exact conductor Fresnel of this index replaces Schlick's
  // from `albedo`.
  glm::vec3 conductor_eta{0.0f};
  glm::vec3 conductor_k{0.0f};

  bool emits() const { return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f; }
  bool is_diffuse() const { return type == MaterialType::kDiffuse; }
  bool has_complex_ior() const { return conductor_eta.x > 0.0f; }
};

// Radiates intensity power / (4 pi) in every direction (the lab's light).
struct PointLight {
  glm::vec3 position{0.0f};
  glm::vec3 power{0.0f};  // P, radiant power per channel
};

// An equirectangular (latitude-longitude) radiance map lighting the scene from infinitely far away
// (render/environment_light.h samples it). Row 0 looks up (-y, the lab's world is y-down), the last
// row down (+y); column u = (x + 0.5) / width runs over azimuth phi = 2 pi (u - 1/2) measured from
// +z towards +x, so the map's centre column faces +z (where the default camera looks) and u = 0
// faces -z. `rotate_degrees` turns the map about the up axis, carrying what the centre column
// shows from +z towards +x. Radiance is texel * scale (nearest texel: piecewise constant).
struct EnvironmentMap {
  int width = 0;
  int height = 0;
  std::vector<glm::vec3> texels;  // row-major, row 0 first, linear RGB
  float scale = 1.0f;
  float rotate_degrees = 0.0f;
  std::string path;  // where it was read from, for messages
};

struct Scene {
  TriangleMesh mesh;
  std::vector<Material> materials;
  std::vector<PointLight> lights;
  glm::vec3 ambient{0.0f};  // the lab's constant indirect light N
  // Radiance arriving from every direction that no surface blocks (the path integrator's constant
  // environment light; the lab integrator ignores it).
  glm::vec3 environment{0.0f};
  // When set, replaces `environment`: radiance from a map, importance-sampled as a light.
  std::shared_ptr<const EnvironmentMap> environment_map;
  Camera camera;
};

}  // namespace tritrace
