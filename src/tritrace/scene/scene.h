// Scene: everything a render reads, built once and then read-only: triangles, materials, point
// lights, the constant indirect (ambient) term, the environment, textures and the camera.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "tritrace/geometry/triangle_mesh.h"
#include "tritrace/image/texture.h"
#include "tritrace/scene/camera.h"

namespace tritrace {

// What a surface does with light (render/material/bsdf.h builds its BSDF from this). The lab
// integrator reads only `albedo` (and shades every type as diffuse, with the lab's one-sided rule).
enum class MaterialType : uint8_t {
  kDiffuse,    // two-sided Lambert, reflectance `albedo`
  kConductor,  // metal: GGX microfacets (a mirror at roughness 0), Schlick Fresnel from F0 = albedo
  kDielectric,  // glass: GGX reflection and refraction with exact Fresnel, index `ior` inside
  kPrincipled,  // glTF metallic-roughness: conductor, glass and coated diffuse mixed by weights
};

// One of Scene::textures, looked up through the mesh's texture coordinates with these wrap modes
// (a glTF sampler's; repeat by default).
struct TextureRef {
  int32_t index = -1;  // none
  WrapMode wrap_s = WrapMode::kRepeat;
  WrapMode wrap_t = WrapMode::kRepeat;
  bool present() const { return index >= 0; }
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
  // Multiply albedo and emission where present (glTF's baseColorTexture times baseColorFactor,
  // emissiveTexture times emissiveFactor). The lab integrator ignores them.
  TextureRef albedo_texture{};
  TextureRef emission_texture{};

  bool emits() const { return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f; }
  bool is_diffuse() const { return type == MaterialType::kDiffuse; }
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
  // Radiance arriving from every direction that no surface blocks (the path integrator's constant
  // environment light; the lab integrator ignores it).
  glm::vec3 environment{0.0f};
  std::vector<Texture> textures;  // shared by the materials that refer to them
  Camera camera;
};

// `factor` times the texture `ref` at texture coordinates uv, or `factor` alone without a texture.
inline glm::vec3 textured(const Scene& scene, const TextureRef& ref, glm::vec3 factor,
                          glm::vec2 uv) {
  if (!ref.present()) return factor;
  return factor * scene.textures[static_cast<size_t>(ref.index)].lookup(uv, ref.wrap_s, ref.wrap_t);
}

}  // namespace tritrace
