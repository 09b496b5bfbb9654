// glTF 2.0 materials as the file's JSON states them, for what assimp 5.2 (Debian 12) drops or
// bends: each texture's coordinate set and KHR_texture_transform, the metallic-roughness, normal
// and transmission textures with the normal map's scale, KHR_materials_emissive_strength,
// KHR_materials_ior and KHR_materials_transmission. The importer (mesh_import.cpp) lays these over
// the material it maps from assimp's keys; docs/SCENE_FORMAT.md, "glTF materials", has the table.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "tritrace/image/texture.h"

namespace tritrace {

// An image of the file: an external file named by its URI, or one assimp decodes itself (a
// bufferView or a data: URI), which it numbers in image order ("*N", aiScene::GetEmbeddedTexture).
struct GltfImage {
  std::string uri;        // external file, relative to the model (empty for an embedded one)
  int32_t embedded = -1;  // assimp's number for an embedded image
};

// A material's reference to a texture (glTF's textureInfo), resolved to its image and sampler.
struct GltfTextureRef {
  int32_t image = -1;  // into GltfMaterialTable::images; -1: none
  WrapMode wrap_s = WrapMode::kRepeat;
  WrapMode wrap_t = WrapMode::kRepeat;
  uint8_t texcoord = 0;  // TEXCOORD_n (KHR_texture_transform's texCoord overrides textureInfo's)
  // KHR_texture_transform's matrix, translation * rotation * scale, carried from glTF's texture
  // space (v down) to tritrace's (v' = 1 - v): TextureRef::transform's layout. The identity
  // without the extension.
  float transform[6] = {1.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f};
  bool present() const { return image >= 0; }
};

struct GltfMaterial {
  std::string name;  // the file's, or empty
  GltfTextureRef base_colour, metallic_roughness, normal, emissive, transmission_texture;
  float normal_scale = 1.0f;
  glm::vec3 emissive_factor{0.0f};
  float emissive_strength = 1.0f;  // KHR_materials_emissive_strength
  std::optional<float> ior;        // KHR_materials_ior
  float transmission = 0.0f;       // KHR_materials_transmission's factor
};

struct GltfMaterialTable {
  // The materials assimp imports, in its numbering (aiScene::mMaterials): the order in which its
  // lazy loader first meets them (gltf_materials.cpp, assimp_load_order), not the file's.
  std::vector<GltfMaterial> materials;
  std::vector<size_t> file_index;  // each one's index in the file's "materials"
  std::vector<GltfImage> images;   // in the file's order
};

// The materials of a glTF document's JSON text. Throws Error(subject, "<JSON pointer>: <reason>")
// for a malformed material, texture, sampler or image entry, or JSON that does not parse.
// texCoord sets beyond TEXCOORD_1 read as TEXCOORD_0.
GltfMaterialTable parse_gltf_materials(std::string_view json, const std::string& subject);

}  // namespace tritrace
