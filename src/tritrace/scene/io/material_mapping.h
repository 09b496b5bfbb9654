// A model file's material, as its keys state it (assimp's aiMaterial keys, or an MTL read by the
// native OBJ reader), mapped to tritrace's Material: one mapping for every importer, so that
// docs/SCENE_FORMAT.md's table holds for each of them. Also the texture table both share.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <map>
#include <optional>
#include <string>

#include "tritrace/scene/io/mesh_import.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// The values a file gives, unchecked (they may be non-finite or out of range; the mapping cleans
// them), each absent where the file does not have the key.
struct MaterialKeys {
  std::optional<glm::vec3> base_colour;  // glTF's base colour
  std::optional<glm::vec3> diffuse;      // Kd
  std::optional<glm::vec3> specular;     // Ks
  std::optional<glm::vec3> emissive;     // Ke
  std::optional<float> emissive_intensity;
  std::optional<float> ior;                                // Ni
  std::optional<float> shininess;                          // Ns, a Phong exponent
  std::optional<float> opacity;                            // d
  std::optional<float> metallic, roughness, transmission;  // glTF's metallic-roughness
  TextureRef albedo_texture;                               // base colour, else diffuse (map_Kd)
  TextureRef emission_texture;                             // map_Ke
};

// glTF's metallic-roughness becomes the principled material; OBJ/MTL's Kd, Ks, Ns, Ni, d, Ke map
// to the type that fits (docs/SCENE_FORMAT.md). Imported materials are two-sided: a file's winding
// says nothing about which side should emit.
Material map_material(const MaterialKeys& keys);

// The images a file's materials refer to, each decoded once into `out.textures` however many
// materials use it. External files are read relative to `directory` (empty for a model read from
// memory, which then cannot refer to one).
class ExternalTextures {
 public:
  ExternalTextures(std::string subject, std::string directory, ImportedMesh& out)
      : subject_(std::move(subject)), directory_(std::move(directory)), out_(out) {}

  // The index of `path` (as the file writes it) in out.textures, reading it the first time.
  int32_t index_of(const std::string& path);

 private:
  std::string subject_;
  std::string directory_;
  ImportedMesh& out_;
  std::map<std::string, int32_t> loaded_;
};

}  // namespace tritrace
